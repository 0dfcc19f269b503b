"""Analytic scenes whose visibility and SSDF are known in closed form.

A vertex sits at the origin of the plane y = 0 (normal +Y). Its CONVENTIONS frame at the pole is
t = +X, b = n × t = −Z, so local (x, y, z) ↔ world (x, z, −y)... i.e. world = x t + y b + z n.
"""

import numpy as np
import pytest

from sgpipe.visibility.trace import build_scene

L = 1000.0          # "infinite" extent of the blocking quads


def quad(a, b, c, d):
    return np.array([[a, b, c], [a, c, d]], float)


def slab_scene():
    """Half-plane slab at height 1 over world x ∈ [0, L]: occludes exactly {w_x > 0}.
    S(w) = min(asin(−w_x), asin(w_y)) on the upper hemisphere."""
    tri = quad((0, 1, -L), (L, 1, -L), (L, 1, L), (0, 1, L))
    return tri, lambda w: np.minimum(np.arcsin(-w[..., 0]), np.arcsin(w[..., 1])), \
        lambda w: (w[..., 0] < 0) & (w[..., 1] > 0)


def wall_scene(a=1.0, h=1.0):
    """Wall x = a, y ∈ [−1, h]: occludes {w_x > 0, w_y ≤ (h/a) w_x}, a lune bounded by the
    horizon and the great circle with normal m ∝ (−h/a, 1, 0)."""
    tri = quad((a, -1, -L), (a, h, -L), (a, h, L), (a, -1, L))
    m = np.array([-h / a, 1.0, 0.0])
    m /= np.linalg.norm(m)

    def ssdf(w):
        wm = w @ m
        proj_y = w[..., 1] - wm * m[1]
        arc = np.where(proj_y >= 0, np.arcsin(np.clip(np.abs(wm), 0, 1)),
                       np.arccos(np.clip(np.abs(w[..., 2]), 0, 1)))
        return np.where(wm <= 0, -np.arcsin(np.clip(-wm, 0, 1)),
                        np.minimum(np.arcsin(np.clip(w[..., 1], 0, 1)), arc))

    return tri, ssdf, lambda w: (w @ m > 0) & (w[..., 1] > 0)


def open_plane_scene():
    """A far-away tiny triangle only (nothing blocks the upper hemisphere): S = asin(w_y)."""
    tri = np.array([[[0, -50, 0], [1, -50, 0], [0, -50, 1]]], float)
    return tri, lambda w: np.arcsin(w[..., 1]), lambda w: w[..., 1] > 0


FRAME = dict(position=np.zeros(3), normal=np.array([0.0, 1.0, 0.0]),
             tangent=np.array([1.0, 0.0, 0.0]), bitangent=np.array([0.0, 0.0, -1.0]))


@pytest.fixture(scope="module")
def scenes():
    out = {}
    for name, fn in (("slab", slab_scene), ("wall", wall_scene), ("open", open_plane_scene)):
        tri, ssdf, vis = fn()
        out[name] = (build_scene(tri), ssdf, vis, tri)
    return out


@pytest.fixture
def frame():
    return FRAME
