"""Sphere point sets, the Shirley–Chiu concentric hemisphere map, and local shading frames."""
from __future__ import annotations

from functools import lru_cache

import numpy as np

_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))
_Y = np.array([0.0, 1.0, 0.0])
_X = np.array([1.0, 0.0, 0.0])


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def fibonacci_sphere(n):
    """n quasi-uniform unit directions (n, 3): y_i = 1 − (2i+1)/n, φ_i = i·golden angle."""
    i = np.arange(int(n), dtype=float)
    y = 1.0 - (2.0 * i + 1.0) / n
    r = np.sqrt(np.maximum(0.0, 1.0 - y * y))
    phi = i * _GOLDEN_ANGLE
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=-1)


def _icosahedron():
    g = (1.0 + np.sqrt(5.0)) / 2.0
    v = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0],
                  [0, -1, g], [0, 1, g], [0, -1, -g], [0, 1, -g],
                  [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
                  [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
                  [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                  [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    return _unit(v), f


def icosahedral_geodesic(freq=3):
    """Geodesic sphere (Green06's 92 views for freq=3): 10f²+2 unit directions, deterministic order.

    Each icosahedron face is split into f² triangles on the flat face (barycentric grid), points
    are projected to the sphere; the 12 icosahedron vertices come first, then new points in
    order of first appearance (faces in the fixed table order).
    """
    f = int(freq)
    if f < 1:
        raise ValueError("freq must be >= 1")
    verts, faces = _icosahedron()
    pts = [v for v in verts]
    keys = {tuple(np.round(v, 9)) for v in verts}
    for a, b, c in faces:
        A, B, C = verts[a], verts[b], verts[c]
        for i in range(f + 1):
            for j in range(f + 1 - i):
                k = f - i - j
                p = (i * A + j * B + k * C) / f
                p = p / np.linalg.norm(p)
                key = tuple(np.round(p, 9))
                if key not in keys:
                    keys.add(key)
                    pts.append(p)
    out = np.array(pts)
    assert len(out) == 10 * f * f + 2
    return out


@lru_cache(maxsize=4)
def icosahedral_view_set(freq: int = 3):
    """Green06 §3.2's view set: (dirs (V, 3), triangles (F, 3) int64, neighbours (V, 6) int64
    padded with −1, neighbour counts (V,)) of the icosahedral geodesic: its triangles are the
    hull faces (outward-wound), its neighbours the hull edges (5 at the 12 icosahedron
    corners, 6 else)."""
    from scipy.spatial import ConvexHull
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


# --- Shirley–Chiu concentric map, area-preserving uniform hemisphere (local frame, z up) ----
def _square_to_disk(u, v):
    a = 2.0 * np.asarray(u, float) - 1.0
    b = 2.0 * np.asarray(v, float) - 1.0
    a, b = np.broadcast_arrays(a, b)
    use_a = np.abs(a) > np.abs(b)
    sa = np.where(a == 0.0, 1.0, a)
    sb = np.where(b == 0.0, 1.0, b)
    r = np.where(use_a, a, b)
    phi = np.where(use_a, (np.pi / 4.0) * (b / sa), np.pi / 2.0 - (np.pi / 4.0) * (a / sb))
    return r * np.cos(phi), r * np.sin(phi)


def _disk_to_square(x, y):
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    r = np.hypot(x, y)
    use_x = np.abs(x) >= np.abs(y)
    # Signed radius s and angle φ so that (x, y) = s (cos φ, sin φ), φ in the forward map's range.
    sx = np.where(x >= 0.0, 1.0, -1.0)
    sy = np.where(y >= 0.0, 1.0, -1.0)
    s = np.where(use_x, sx * r, sy * r)
    phi = np.arctan2(np.where(use_x, sx * y, sy * y), np.where(use_x, sx * x, sy * x))
    a = np.where(use_x, s, s * (np.pi / 2.0 - phi) * (4.0 / np.pi))
    b = np.where(use_x, s * phi * (4.0 / np.pi), s)
    return 0.5 * (a + 1.0), 0.5 * (b + 1.0)


def concentric_square_to_hemisphere(u, v):
    """Shirley–Chiu 1997: (u, v) ∈ [0,1]² → uniform (area-preserving) hemisphere, z = 1 − r².

    The concentric square→disk map preserves area, and disk→hemisphere (z = 1 − r²,
    xy scaled by sqrt(2 − r²)) has dω = 2 r dr dφ, so equal square areas get equal solid
    angle: every texel of a res×res image covers exactly 2π/res² sr. NOT cosine-weighted.
    """
    x, y = _square_to_disk(u, v)
    r2 = x * x + y * y
    s = np.sqrt(np.maximum(0.0, 2.0 - r2))
    return np.stack([x * s, y * s, 1.0 - r2], axis=-1)


def hemisphere_to_concentric_square(d):
    """Inverse of concentric_square_to_hemisphere for local directions with z >= 0 → (u, v)."""
    d = np.asarray(d, float)
    z = np.clip(d[..., 2], 0.0, 1.0)
    r = np.sqrt(1.0 - z)
    rho = np.hypot(d[..., 0], d[..., 1])
    scale = np.where(rho > 0.0, r / np.where(rho > 0.0, rho, 1.0), 0.0)
    return _disk_to_square(d[..., 0] * scale, d[..., 1] * scale)


def concentric_texel_solid_angle(res):
    """Solid angle of every texel of a res×res concentric hemisphere map: 2π / res²."""
    return 2.0 * np.pi / float(res) ** 2


# --- Local shading frame ------------------------------------------------------------------
def tangent_frame(n, t_hint=None):
    """CONVENTIONS frame: returns (t, b) with b = n × t, both unit and ⟂ n.

    Default tangent: the azimuthal direction about +Y, t = normalize(n × ŷ). This is the
    direction of increasing lat-long u (φ) of the CONVENTIONS mapping, so a sphere with lat-long
    UVs gets the same tangent from its UVs; b = n × t then points along increasing v (south).
    Poles (|n × ŷ| < 1e-8) use t = +X projected onto the tangent plane. With t_hint, t is
    t_hint Gram–Schmidt-orthogonalised against n (falling back to the default if ∥ n).
    """
    n = _unit(n)
    t_def = np.cross(n, _Y)
    ln = np.linalg.norm(t_def, axis=-1, keepdims=True)
    x_proj = _X - n[..., :1] * n  # +X minus its n component
    x_len = np.linalg.norm(x_proj, axis=-1, keepdims=True)
    t = np.where(ln > 1e-8, t_def / np.where(ln > 1e-8, ln, 1.0), x_proj / np.maximum(x_len, 1e-30))
    if t_hint is not None:
        th = np.asarray(t_hint, float)
        th = th - np.sum(th * n, axis=-1, keepdims=True) * n
        lh = np.linalg.norm(th, axis=-1, keepdims=True)
        t = np.where(lh > 1e-8, th / np.where(lh > 1e-8, lh, 1.0), t)
    b = np.cross(n, t)
    return t, b


def turn_frame(t, b, angle):
    """(t', b') = the tangent and bitangent turned by `angle` (radians, scalar or (N,)) about
    their normal, from t towards b: t' = cos·t + sin·b, b' = cos·b − sin·t (an anisotropic
    BRDF's direction, KHR_materials_anisotropy's anisotropyRotation)."""
    c = np.cos(np.asarray(angle, float))[..., None]
    s = np.sin(np.asarray(angle, float))[..., None]
    t, b = np.asarray(t, float), np.asarray(b, float)
    return c * t + s * b, c * b - s * t


def to_local(d, n, t, b):
    """World → local (x along t, y along b, z along n)."""
    d = np.asarray(d, float)
    return np.stack([np.sum(d * t, -1), np.sum(d * b, -1), np.sum(d * n, -1)], axis=-1)


def to_world(d, n, t, b):
    """Local (x, y, z) = (t, b, n) components → world."""
    d = np.asarray(d, float)
    return d[..., :1] * t + d[..., 1:2] * b + d[..., 2:3] * n
