"""Fixed per-resolution tables of the concentric hemisphere image (Shirley–Chiu, local z-up).

Texel (row r, column c) of an R×R image is the direction concentric_square_to_hemisphere(u, v)
with u = (c + 0.5)/R, v = (r + 0.5)/R (docs/ARTIFACTS.md, visibility/).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from sgpipe.core.sphere import concentric_square_to_hemisphere


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@lru_cache(maxsize=8)
def texel_dirs(res: int) -> np.ndarray:
    """(R, R, 3) float64 local unit directions of the texel centres."""
    c = (np.arange(res) + 0.5) / res
    d = concentric_square_to_hemisphere(c[None, :], c[:, None])
    return _readonly(d / np.linalg.norm(d, axis=-1, keepdims=True))


@lru_cache(maxsize=4)
def texel_dirs_f32(res: int) -> np.ndarray:
    """(R·R, 3) float32 C-contiguous copy of texel_dirs (the traced ray directions, local)."""
    return _readonly(np.ascontiguousarray(texel_dirs(res).reshape(-1, 3), dtype=np.float32))


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@lru_cache(maxsize=4)
def neighbour_midpoints(res: int) -> tuple[np.ndarray, np.ndarray]:
    """Great-circle midpoints between 4-neighbouring texels: (R, R−1, 3) across columns and
    (R−1, R, 3) across rows. A visibility boundary is represented by these points."""
    d = texel_dirs(res)
    return (_readonly(_unit(d[:, 1:] + d[:, :-1])), _readonly(_unit(d[1:, :] + d[:-1, :])))


def texel_spacing(res: int) -> float:
    """Typical angular spacing of texel centres: √(2π/R²) (every texel has solid angle 2π/R²)."""
    return float(np.sqrt(2.0 * np.pi) / res)


def _caps(dirs: np.ndarray, size: int, extend: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounding caps of size×size tiles of a direction image (tiles grown by `extend` texels):
    centres (n, n, 3), cos and sin of the angular radii (n, n)."""
    res = dirs.shape[0]
    n = (res + size - 1) // size
    cen = np.empty((n, n, 3))
    rad = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            blk = dirs[i * size:min(res, (i + 1) * size + extend),
                       j * size:min(res, (j + 1) * size + extend)].reshape(-1, 3)
            c = _unit(blk.mean(axis=0))
            cen[i, j] = c
            rad[i, j] = np.arccos(np.clip(blk @ c, -1.0, 1.0)).max() * (1.0 + 1e-9) + 1e-12
    return cen, np.cos(rad), np.sin(rad)


@lru_cache(maxsize=8)
def query_caps(res: int, block: int):
    """Caps of block×block groups of output texels (branch and bound of the SSDF search)."""
    return tuple(_readonly(a) for a in _caps(texel_dirs(res), block, 0))


@lru_cache(maxsize=8)
def boundary_tile_caps(trace_res: int, tile: int):
    """Caps of tile×tile groups of trace texels, grown by one texel so that they contain the
    midpoints bucketed into them (a cap of radius < π/2 is convex). Flattened to (n², ...)."""
    cen, cs, sn = _caps(texel_dirs(trace_res), tile, 1)
    return (_readonly(cen.reshape(-1, 3).copy()), _readonly(cs.ravel().copy()),
            _readonly(sn.ravel().copy()))


@lru_cache(maxsize=8)
def max_texel_spacing(res: int) -> float:
    """Largest angle between 4-neighbouring texel centres (≈ 1.7 × texel_spacing, near the
    horizon diagonals): the resolution bound of boundary positions in an R×R image."""
    d = texel_dirs(res)
    a = np.sum(d[:, 1:] * d[:, :-1], axis=-1).min()
    b = np.sum(d[1:] * d[:-1], axis=-1).min()
    return float(np.arccos(np.clip(min(a, b), -1.0, 1.0)))
