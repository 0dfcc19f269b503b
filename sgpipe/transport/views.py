"""Green06 §3.2: the 92 icosahedral view directions (global frame), their neighbour graph and
the three-nearest-views lookup with barycentric weights used to interpolate across views."""

from __future__ import annotations

import numpy as np

from sgpipe.artifacts.transport import N_VIEWS  # noqa: F401  (the artifact's mask width)
from sgpipe.core.sphere import icosahedral_view_set as view_set


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
