"""Reading and validating tangent-space normal maps (docs/HAN07.md "Input"; CONVENTIONS
"Shading frame, tangents, UVs, normal maps").

Every supported file stores a unit normal n as c = (n + 1)/2 per channel: 8- and 16-bit PNG
as integers scaled to [0, 1], EXR as floats (the encoding sgpipe's renderer decodes today,
`normal_from_map` in render/kernels/include/shading.h, and data_samples/normal_map.exr). The
decode is the renderer's: n = 2c − 1, n_z = max(n_z, 10⁻³), normalised.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io import read_data_image

#: The formats read here (extension → what it holds).
SUPPORTED = {".png": "8- or 16-bit PNG", ".exr": "float EXR (half or full)"}
MAX_SIDE = 8192
#: Below this length 2c − 1 is no direction (an 8-bit mid-grey (128,128,128) is 0.0068).
MIN_LENGTH = 0.05
#: EXR values may overshoot [0, 1] by rounding (half floats) but not by more.
EXR_SLACK = 1e-3
#: The renderer's floor on the decoded z (normal_from_map): keeps n in the upper hemisphere.
Z_FLOOR = 1e-3


def _first_texel(mask: np.ndarray) -> str:
    r, c = np.argwhere(mask)[0]
    return f"first at row {int(r)}, column {int(c)}"


def read_raw(path: str | Path, key: str | None) -> tuple[np.ndarray, str]:
    """The file's texels as float64 (H, W, C) in its own units (PNG: [0, 1]) and a word for
    its pixel format; BadInput for missing, unreadable or unsupported files."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in SUPPORTED:
        raise BadInput(f"unsupported normal-map format {ext or '(none)'!r}; supported: "
                       + ", ".join(f"{v} ({k})" for k, v in SUPPORTED.items()), file=path,
                       key=key)
    if not path.is_file():
        raise BadInput("file not found", file=path, key=key)
    img, fmt = read_data_image(path, key)
    return img.astype(np.float64), fmt


def decode_normals(c: np.ndarray) -> np.ndarray:
    """Texel values (n + 1)/2 → unit normals, as the renderer decodes them (no validation)."""
    n = 2.0 * np.asarray(c, np.float64)[..., :3] - 1.0
    n[..., 2] = np.maximum(n[..., 2], Z_FLOOR)
    return n / np.sqrt(n[..., 0] ** 2 + n[..., 1] ** 2 + n[..., 2] ** 2)[..., None]


def validate_texels(img: np.ndarray, path, key, *, is_exr: bool) -> None:
    """BadInput (naming file and key) unless img is a square power-of-two 3/4-channel map of
    finite values that decode to non-zero normals."""
    h, w, ch = img.shape
    if ch not in (3, 4):
        raise BadInput(f"has {ch} channel{'s' if ch != 1 else ''}; a tangent-space normal map "
                       "needs 3 (RGB = (n + 1)/2) or 4 (RGBA, alpha ignored)", file=path, key=key)
    if h != w or w < 2 or w > MAX_SIDE or (w & (w - 1)):
        raise BadInput(f"is {w}×{h}; supported: square maps with a power-of-two side from 2 to "
                       f"{MAX_SIDE} (the MIP pyramid halves the side per level)", file=path,
                       key=key)
    rgb = img[..., :3]
    bad = ~np.isfinite(rgb).all(axis=2)
    if bad.any():
        raise BadInput(f"{int(bad.sum())} texels are NaN/Inf ({_first_texel(bad)})", file=path,
                       key=key)
    if is_exr:
        out = ((rgb < -EXR_SLACK) | (rgb > 1.0 + EXR_SLACK)).any(axis=2)
        if out.any():
            raise BadInput(f"{int(out.sum())} texels lie outside [0, 1] ({_first_texel(out)}); "
                           "EXR normal maps store (n + 1)/2 like PNGs (sgpipe's renderer decodes "
                           "2c − 1), this looks like signed normals: store n·0.5 + 0.5",
                           file=path, key=key)
    n = 2.0 * rgb - 1.0
    short = np.sqrt(n[..., 0] ** 2 + n[..., 1] ** 2 + n[..., 2] ** 2) < MIN_LENGTH
    if short.any():
        raise BadInput(f"{int(short.sum())} texels hold zero-length normals (|2c − 1| < "
                       f"{MIN_LENGTH}; {_first_texel(short)})", file=path, key=key)


def read_normal_texels(path: str | Path, key: str | None = None) -> np.ndarray:
    """The validated texel values c = (n + 1)/2 (N, N, 3) float64 of a normal-map file, before
    decoding (what a bilinear read interpolates)."""
    img, fmt = read_raw(path, key)
    validate_texels(img, path, key, is_exr=Path(path).suffix.lower() == ".exr")
    return np.ascontiguousarray(img[..., :3])


def read_normal_map(path: str | Path, key: str | None = None) -> np.ndarray:
    """Unit tangent-space normals (N, N, 3) float64 of a normal-map file; row 0 is the top of
    the image (v = 1, OBJ convention), +x along u, +y along v, +z the geometric normal."""
    return decode_normals(read_normal_texels(path, key))


def check_object_uvs(cfg) -> None:
    """BadInput for a scene object with a normal map whose mesh has no texture coordinates
    (OBJ `vt`); analytic spheres carry lat-long UVs (CONVENTIONS)."""
    from sgpipe.io.mesh import load_object
    if cfg.scene is None:
        return
    for k, o in enumerate(cfg.scene.objects):
        if o.normal_map is None or o.mesh is None:
            continue
        if not load_object(o, k).has_uvs:
            raise BadInput(f"object {o.name!r} has a normal map but its mesh has no texture "
                           "coordinates (OBJ `vt`); a normal map needs UVs",
                           file=o.mesh, key=f"scene.objects.{k}.normal_map")
