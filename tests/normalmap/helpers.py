"""Small normal maps written in each supported format (8/16-bit PNG through OpenImageIO, EXR)."""

from __future__ import annotations

import numpy as np


def write_image(path, img, fmt: str) -> None:
    """img (H, W, C) in [0, 1] (or any float for 'float') as uint8 / uint16 PNG or EXR."""
    import OpenImageIO as oiio
    img = np.asarray(img, np.float64)
    h, w, c = img.shape
    if fmt == "uint8":
        data, t = np.round(np.clip(img, 0, 1) * 255).astype(np.uint8), oiio.UINT8
    elif fmt == "uint16":
        data, t = np.round(np.clip(img, 0, 1) * 65535).astype(np.uint16), oiio.UINT16
    else:
        data, t = img.astype(np.float32), oiio.FLOAT
    out = oiio.ImageOutput.create(str(path))
    assert out is not None and out.open(str(path), oiio.ImageSpec(w, h, c, t))
    out.write_image(np.ascontiguousarray(data))
    out.close()


def tilted_normals(n: int, seed: int = 0, spread: float = 0.4) -> np.ndarray:
    """Random unit normals in the upper hemisphere (n, n, 3)."""
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, n, 3)) * spread
    v[..., 2] = 1.0
    return v / np.linalg.norm(v, axis=-1, keepdims=True)
