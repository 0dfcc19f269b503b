"""Green06 §3.2: the 92 icosahedral view directions (global frame), their neighbour graph and
the three-nearest-views lookup with barycentric weights used to interpolate across views."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.spatial import ConvexHull

from sgpipe.artifacts.transport import N_VIEWS  # noqa: F401  (the artifact's mask width)
from sgpipe.core.sphere import icosahedral_geodesic


@lru_cache(maxsize=4)
def view_set(freq: int = 3):
    """(dirs (V, 3), triangles (F, 3) int64, neighbours (V, 6) int64 padded with −1,
    neighbour counts (V,)) of the icosahedral geodesic: its triangles are the hull faces
    (outward-wound), its neighbours the hull edges (5 at the 12 icosahedron corners, 6 else)."""
    dirs = icosahedral_geodesic(freq)
    hull = ConvexHull(dirs)
    tri = np.asarray(hull.simplices, np.int64)
    # outward winding: (b − a) × (c − a) points along the face's centroid
    a, b, c = dirs[tri[:, 0]], dirs[tri[:, 1]], dirs[tri[:, 2]]
    flip = np.einsum("ij,ij->i", np.cross(b - a, c - a), a + b + c) < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    tri = tri[np.lexsort(tri.T[::-1])]            # a fixed order, independent of qhull's
    nb = [set() for _ in range(len(dirs))]
    for i, j, k in tri:
        nb[i] |= {j, k}
        nb[j] |= {i, k}
        nb[k] |= {i, j}
    width = max(len(s) for s in nb)
    table = np.full((len(dirs), width), -1, np.int64)
    for v, s in enumerate(nb):
        table[v, :len(s)] = sorted(s)
    counts = np.array([len(s) for s in nb], np.int64)
    for arr in (dirs, tri, table, counts):
        arr.setflags(write=False)
    return dirs, tri, table, counts


def nearest_views(q, freq: int = 3):
    """The three views around direction(s) q (..., 3) and barycentric weights (..., 3).

    The geodesic triangle containing q is the hull face its ray crosses; the weights are the
    planar barycentric coordinates of that crossing point (gnomonic projection), so
    Σ b_i v_i is parallel to q: interpolating any quantity linear in v (a reflected direction,
    a rotated mean) reproduces it exactly at q."""
    dirs, tri, _, _ = view_set(freq)
    q = np.asarray(q, float)
    flat = q.reshape(-1, 3)
    a, b, c = dirs[tri[:, 0]], dirs[tri[:, 1]], dirs[tri[:, 2]]
    # barycentrics of the ray q through every face: solve [a b c] β = s q (β normalised)
    M = np.stack([a, b, c], axis=-1)                 # (F, 3, 3) columns a, b, c
    Minv = np.linalg.inv(M)
    beta = np.einsum("fij,nj->nfi", Minv, flat)       # (n, F, 3) ∝ barycentrics
    inside = np.all(beta >= -1e-12, axis=-1)
    face = np.argmax(inside, axis=1)                  # first face whose cone holds q
    bsel = beta[np.arange(len(flat)), face]
    bsel = np.maximum(bsel, 0.0)
    bsel /= bsel.sum(-1, keepdims=True)
    idx = tri[face]
    return idx.reshape(q.shape[:-1] + (3,)), bsel.reshape(q.shape[:-1] + (3,))


__all__ = ["N_VIEWS", "view_set", "nearest_views"]
