"""Spherical signed distance functions from binary hemisphere visibility (Wang09 eq 23).

Definition used everywhere (docs/ARTIFACTS.md, visibility/):
  * V is sampled at the T×T trace texels; directions below the tangent plane are occluded.
  * The output texel (row r, column c) of the R×R image (T = k·R) is visible iff at least
    half of its k×k trace texels are (the anti-aliasing downsample of Wang09 §5.2).
  * The boundary is the set of great-circle midpoints between 4-neighbouring trace texels of
    different visibility, plus the horizon.
  * S = +(angle to the nearest boundary point, or to the horizon = asin(z)) where visible,
    −(angle to the nearest boundary point) where occluded; exact angles on the sphere; the
    magnitude is clamped to max_distance (fully visible/occluded images included).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from sgpipe.visibility import _ssdf_jit
from sgpipe.visibility.hemigrid import (boundary_tile_caps, neighbour_midpoints, query_caps,
                                        texel_dirs)

_QUERY_BLOCK = 8
_BOUNDARY_TILE = 16


def downsample_visibility(vis: np.ndarray, res: int) -> np.ndarray:
    """(T, T) bool → (R, R) float32 fraction of visible trace texels per output texel."""
    t = vis.shape[0]
    if vis.shape != (t, t) or t % res:
        raise ValueError(f"visibility image {vis.shape} is not a multiple of {res}")
    vis = np.ascontiguousarray(vis, dtype=np.bool_)
    if (t // res) % 4 == 0:
        return _ssdf_jit.block_fraction_words(vis.view(np.uint32), res)
    return _ssdf_jit.block_fraction(vis, res)


def _boundary_pairs(vis: np.ndarray):
    """Row/column indices of horizontal and vertical 4-neighbour pairs that differ."""
    rh, ch = np.nonzero(vis[:, 1:] != vis[:, :-1])
    rv, cv = np.nonzero(vis[1:, :] != vis[:-1, :])
    return rh, ch, rv, cv


def boundary_points(vis: np.ndarray) -> np.ndarray:
    """(M, 3) local directions of the visibility boundary of a (T, T) bool image."""
    mh, mv = neighbour_midpoints(vis.shape[0])
    rh, ch, rv, cv = _boundary_pairs(vis)
    return np.concatenate([mh[rh, ch], mv[rv, cv]], axis=0)


def _boundary_by_tile(vis: np.ndarray, tile: int):
    """Boundary points sorted by the trace tile of their first texel, with CSR offsets."""
    mh, mv = neighbour_midpoints(vis.shape[0])
    t = vis.shape[0]
    if t % 8:                           # whole uint64 words per row (zero padding)
        words = np.zeros((t, t + (-t) % 8), np.bool_)
        words[:, :t] = vis
    else:
        words = np.ascontiguousarray(vis)
    return _ssdf_jit.boundary_by_tile(vis, words.view(np.uint64), mh, mv, tile)


def nearest_boundary_angle(vis: np.ndarray, res: int, bound: np.ndarray | None = None
                           ) -> np.ndarray:
    """(R, R) exact angle from every output texel centre to the nearest boundary point of
    the (T, T) bool visibility, or `bound` (default π) where that is smaller."""
    t = vis.shape[0]
    tile = min(_BOUNDARY_TILE, t)
    pts, start = _boundary_by_tile(vis, tile)
    block = min(_QUERY_BLOCK, res)
    bcen, bcos, bsin = query_caps(res, block)
    tcen, tcos, tsin = _ssdf_jit.point_caps(pts, start, *boundary_tile_caps(t, tile))
    if bound is None:
        bound = np.full((res, res), np.pi)
    return _ssdf_jit.nearest_boundary_angle(texel_dirs(res), np.asarray(bound, np.float64),
                                            block, bcen, bcos, bsin, pts, start, tcen, tcos,
                                            tsin)


def ssdf_from_visibility(vis: np.ndarray, res: int, *, max_distance: float = np.pi / 2
                         ) -> np.ndarray:
    """Wang09 eq 23 on the sphere: (T, T) bool visibility → (R, R) float32 SSDF (radians)."""
    vis = np.ascontiguousarray(vis, dtype=np.bool_)
    visible = downsample_visibility(vis, res) >= 0.5
    elevation = _elevation(res)
    # distances beyond the horizon (visible texels) or the clamp are never needed
    bound = np.where(visible, np.minimum(elevation, max_distance), max_distance)
    dist = nearest_boundary_angle(vis, res, bound)
    s = np.where(visible, np.minimum(dist, elevation), -dist)
    return np.clip(s, -max_distance, max_distance).astype(np.float32)


@lru_cache(maxsize=4)
def _elevation(res: int) -> np.ndarray:
    e = np.arcsin(np.clip(texel_dirs(res)[..., 2], -1.0, 1.0))
    e.setflags(write=False)
    return e


def ssdf_bruteforce(vis: np.ndarray, res: int, *, max_distance: float = np.pi / 2
                    ) -> np.ndarray:
    """Same definition as ssdf_from_visibility by exhaustive arccos (for tests; small images)."""
    vis = np.asarray(vis, dtype=bool)
    visible = downsample_visibility(vis, res) >= 0.5
    q = texel_dirs(res).reshape(-1, 3)
    pts = boundary_points(vis)
    if len(pts):
        ang = np.arccos(np.clip(q @ pts.T, -1.0, 1.0)).min(axis=1).reshape(res, res)
    else:
        ang = np.full((res, res), np.pi)
    elev = np.arcsin(np.clip(q[:, 2], -1, 1)).reshape(res, res)
    s = np.where(visible, np.minimum(ang, elev), -ang)
    return np.clip(s, -max_distance, max_distance)


def ssdf_eq23_samples(vis: np.ndarray, res: int, *, max_distance: float = np.pi / 2
                      ) -> np.ndarray:
    """Literal eq 23 over the trace samples: angle to the nearest sample of the other class
    (below-horizon directions count as occluded). Differs from the boundary-midpoint SSDF by
    at most about one trace-texel spacing; used by tests as an independent brute force."""
    vis = np.asarray(vis, dtype=bool)
    visible = downsample_visibility(vis, res) >= 0.5
    q = texel_dirs(res).reshape(-1, 3)
    d = texel_dirs(vis.shape[0]).reshape(-1, 3)
    v = vis.ravel()
    cos = q @ d.T
    big = -2.0
    to_occ = np.arccos(np.clip(np.where(~v[None, :], cos, big).max(axis=1), -1, 1))
    to_vis = np.arccos(np.clip(np.where(v[None, :], cos, big).max(axis=1), -1, 1))
    to_vis = np.where(v.any(), to_vis, np.pi)
    elev = np.arcsin(np.clip(q[:, 2], -1, 1))
    s = np.where(visible.ravel(), np.minimum(to_occ, elev), -to_vis).reshape(res, res)
    return np.clip(s, -max_distance, max_distance)
