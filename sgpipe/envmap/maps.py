"""Environment-map I/O and conversions: lat-long ↔ cubemap ↔ dual paraboloid (Töral19 eq 11).

Cubemaps are (6, n, n, C) arrays in OpenGL face order (rows ↔ t, columns ↔ s, as
`sgpipe.core.maps.cubemap_texel_dirs`); `sgpipe.core.maps.faces_to_image` stacks them vertically for EXR files.
Dual-paraboloid maps are (2, n, n, C) (hemisphere 0 = +Z, 1 = −Z, `core.maps` convention) and
are stored side by side as (n, 2n, C).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sgpipe.core.maps import (bordered_box_level, cubemap_solid_angles,
                              dual_paraboloid_texel_dirs, latlong_texel_dirs)
from sgpipe.envmap._cube_jit import latlong_to_cube_jit, sample_dirs_bordered
from sgpipe.errors import BadInput
from sgpipe.io import read_exr

KEY = "envmap.environment"
#: Radiance above this overflows float32 in the sums over a map (irradiance, pyramid levels).
MAX_RADIANCE = 1e30
#: Rows of the largest map read: 8192 × 16384 is 3.2 GB as the float64 working copy.
MAX_ROWS = 8192


def read_environment(path: str | Path, *, key: str = KEY) -> np.ndarray:
    """Read a lat-long HDR map (EXR/HDR, width / height between 1.5 and 2.5, at most MAX_ROWS
    rows, 3 or 4 channels) → (H, W, 3) float64.

    Missing/unreadable files, NaN/Inf and other channel counts are BadInput naming the file and
    `key`; so are a map with negative radiance (radiance is non-negative) or radiance above
    MAX_RADIANCE, and other shapes."""
    img = read_exr(path, channels=(3, 4), key=key)
    h, w = img.shape[:2]
    if h < 2 or w < 2:
        raise BadInput(f"image is {w}x{h}: too small for a lat-long map", file=path, key=key)
    if not 1.5 <= w / h <= 2.5:
        raise BadInput(f"image is {w}x{h}: a lat-long map is twice as wide as it is high",
                       file=path, key=key)
    if h > MAX_ROWS:
        raise BadInput(f"image is {w}x{h}: more than {MAX_ROWS} rows (downsample it first)",
                       file=path, key=key)
    img = np.asarray(img[:, :, :3], dtype=np.float64)
    neg = int((img < 0).any(axis=2).sum())
    if neg:
        raise BadInput(f"contains negative radiance in {neg} pixels", file=path, key=key)
    big = int((img > MAX_RADIANCE).any(axis=2).sum())
    if big:
        raise BadInput(f"radiance above {MAX_RADIANCE:g} in {big} pixels (sums over the map "
                       "would overflow float32)", file=path, key=key)
    return img


def latlong_to_cubemap(img: np.ndarray, res: int, *, supersample: int | None = None) -> np.ndarray:
    """Lat-long (H, W, C) → cubemap (6, res, res, C): each texel is the solid-angle-weighted
    mean of ss×ss bilinear samples (φ wraps, rows reflect across the poles)."""
    img = np.ascontiguousarray(img, dtype=np.float64)
    if supersample is None:
        # sub-samples at least twice as dense as the lat-long rows
        supersample = int(np.clip(math.ceil(4.0 * img.shape[0] / (math.pi * res)), 2, 8))
    return latlong_to_cube_jit(img, int(res), int(supersample))


def sample_cubemap(faces: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Bilinear lookup of a cubemap (seamless through a 1-texel border) at dirs (..., 3)."""
    b = bordered_box_level(np.asarray(faces, np.float64))
    d = np.ascontiguousarray(np.asarray(dirs, float).reshape(-1, 3))
    out = sample_dirs_bordered(b, faces.shape[1], 1, d, False)
    return out.reshape(np.shape(dirs)[:-1] + (faces.shape[3],))


def cubemap_to_latlong(faces: np.ndarray, h: int, w: int) -> np.ndarray:
    """Cubemap → lat-long (h, w, C) by bilinear lookup at the pixel-centre directions."""
    return sample_cubemap(faces, latlong_texel_dirs(h, w))


def cubemap_to_dual_paraboloid(faces: np.ndarray, res: int, b: float = 1.0, *,
                               supersample: int = 2) -> np.ndarray:
    """Cubemap → dual paraboloid (2, res, res, C) (Töral19 eq 11 with scale b): each texel
    is the solid-angle-weighted mean (dω ∝ (1 + ρ²)^−2) of ss×ss bilinear cube samples
    (sgpipe.core.maps.dual_paraboloid_resample)."""
    from sgpipe.core.maps import dual_paraboloid_resample
    bord = bordered_box_level(np.asarray(faces, np.float64))
    n = faces.shape[1]

    def sample(d):
        return sample_dirs_bordered(bord, n, 1, np.ascontiguousarray(d.reshape(-1, 3)),
                                    False).reshape(d.shape[:-1] + (-1,))
    return dual_paraboloid_resample(sample, res, b, supersample)


def dual_paraboloid_to_image(dp: np.ndarray) -> np.ndarray:
    """(2, n, n, C) → (n, 2n, C): hemisphere 0 left, hemisphere 1 right."""
    return np.concatenate([dp[0], dp[1]], axis=1)


def image_to_dual_paraboloid(img: np.ndarray) -> np.ndarray:
    n = img.shape[0]
    return np.stack([img[:, :n], img[:, n:]])


def sample_dual_paraboloid(dp: np.ndarray, dirs: np.ndarray, b: float = 1.0) -> np.ndarray:
    """Bilinear lookup of a dual-paraboloid map (2, n, n, C) at dirs (..., 3): hemisphere by
    the sign of z, clamp-to-edge inside the chosen half."""
    from sgpipe.core.maps import dir_to_dual_paraboloid
    d = np.asarray(dirs, float).reshape(-1, 3)
    n = dp.shape[1]
    hemi, s, t = dir_to_dual_paraboloid(d, b)
    u = s * n - 0.5
    v = t * n - 0.5
    j0 = np.floor(u).astype(int)
    i0 = np.floor(v).astype(int)
    fu = (u - j0)[:, None]
    fv = (v - i0)[:, None]

    def at(i, j):
        return dp[hemi, np.clip(i, 0, n - 1), np.clip(j, 0, n - 1)]

    out = ((1 - fv) * ((1 - fu) * at(i0, j0) + fu * at(i0, j0 + 1))
           + fv * ((1 - fu) * at(i0 + 1, j0) + fu * at(i0 + 1, j0 + 1)))
    return out.reshape(np.shape(dirs)[:-1] + (dp.shape[3],))


def dual_paraboloid_to_cubemap(dp: np.ndarray, res: int, b: float = 1.0) -> np.ndarray:
    """Dual paraboloid → cubemap (6, res, res, C) by bilinear lookup at texel centres."""
    from sgpipe.core.maps import cubemap_texel_dirs
    return sample_dual_paraboloid(dp, cubemap_texel_dirs(res), b)


def cubemap_power(faces: np.ndarray) -> np.ndarray:
    """∫ L dω of a cubemap with exact texel solid angles → (C,)."""
    om = cubemap_solid_angles(faces.shape[1])
    return np.tensordot(om, faces, axes=([0, 1, 2], [0, 1, 2]))


def dual_paraboloid_texels(res: int, b: float = 1.0):
    """(dirs (2, res, res, 3), valid mask (2, res, res)) of a dual-paraboloid map."""
    from sgpipe.core.maps import dual_paraboloid_valid_mask
    return dual_paraboloid_texel_dirs(res, b), dual_paraboloid_valid_mask(res, b)
