"""PNG previews, and reading 8/16-bit data images (textures, normal maps).

Tone mapping (docs/guide/render-and-compare.md, "The metrics"): exposure scale, then a plain
clamp to [0, 1] (no Reinhard x/(1+x), so that values <= 1 keep their meaning), then the sRGB
transfer curve, 8 bits."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io.atomic import atomic_path
from sgpipe.io.disk import raise_if_disk_full
from sgpipe.io.exr import oiio_error


def linear_to_srgb(x) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of linear values in [0, 1]."""
    x = np.asarray(x, np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(c) -> np.ndarray:
    """The sRGB transfer function's inverse: encoded values in [0, 1] to linear."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def tonemap_srgb(image: np.ndarray, *, exposure: float = 0.0) -> np.ndarray:
    """Linear radiance -> 8-bit sRGB: scale by 2**exposure, clamp to [0, 1], sRGB OETF."""
    x = np.clip(np.nan_to_num(np.asarray(image, np.float64)) * (2.0 ** exposure), 0.0, 1.0)
    return np.round(linear_to_srgb(x) * 255.0).astype(np.uint8)


def write_png(path: str | os.PathLike, image: np.ndarray, *, exposure: float = 0.0,
              already_8bit: bool = False) -> Path:
    """Write a preview PNG atomically. Float input is tone mapped with `tonemap_srgb`."""
    import OpenImageIO as oiio
    path = Path(path)
    img = np.asarray(image)
    if not already_8bit:
        img = tonemap_srgb(img, exposure=exposure)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.shape[2] == 2 or img.shape[2] > 4:
        img = img[:, :, :3] if img.shape[2] > 4 else np.concatenate([img, img[:, :, :1]], 2)
    h, w, c = img.shape
    spec = oiio.ImageSpec(w, h, c, oiio.UINT8)
    spec.attribute("Software", "sgpipe")
    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create(str(tmp))
        if out is None or not out.open(str(tmp), spec):
            raise_if_disk_full(path, img.size)
            raise OSError(f"{path}: cannot write PNG: {oiio_error(oiio)}")
        ok = out.write_image(np.ascontiguousarray(img.astype(np.uint8)))
        ok = out.close() and ok
        # the PNG writer reports a short write only as a pending error message, not as a
        # False return; a truncated file must not be renamed into place
        if not ok or out.has_error:
            raise_if_disk_full(path, img.size)
            raise OSError(f"{path}: cannot write PNG: {oiio_error(out)[:300]}")
    return path


def read_data_image(path: str | os.PathLike, key: str | None = None) -> tuple[np.ndarray, str]:
    """A data image's texels as float32 (H, W, C), integer formats normalised to [0, 1], no
    colour decoding and alpha unassociated (it must not scale RGB), with its pixel format's
    name; BadInput naming the file and key when it cannot be read."""
    import OpenImageIO as oiio
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(str(path), config)
    if inp is None:
        raise BadInput(f"unreadable image ({oiio_error(oiio) or 'unknown format'})",
                       file=path, key=key)
    try:
        fmt = str(inp.spec().format)
        data = inp.read_image(oiio.FLOAT)
    finally:
        inp.close()
    if data is None or np.size(data) == 0:
        raise BadInput("unreadable image (no pixels)", file=path, key=key)
    img = np.asarray(data, np.float32)
    return (img if img.ndim == 3 else img[..., None]), fmt
