"""Environment-map parameterisations: lat-long (docs/CONVENTIONS.md), OpenGL cubemap, dual paraboloid (Töral19 eq 9–11).

Texel (row i, column j) of any map has its centre at ((j + 0.5)/W, (i + 0.5)/H) in [0,1]².
"""
from __future__ import annotations

import numpy as np

_TWO_PI = 2.0 * np.pi


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# --- lat-long --------------------------------------------------------------------------------
def latlong_dir(u, v):
    """CONVENTIONS: φ = 2πu, θ = πv, d = (sinθ sinφ, cosθ, −sinθ cosφ); v = 0 is +Y, u = 0 is −Z."""
    phi = _TWO_PI * np.asarray(u, float)
    theta = np.pi * np.asarray(v, float)
    st = np.sin(theta)
    return np.stack(np.broadcast_arrays(st * np.sin(phi), np.cos(theta), -st * np.cos(phi)), axis=-1)


def dir_to_latlong(d):
    """Inverse of latlong_dir → (u ∈ [0,1), v ∈ [0,1])."""
    d = np.asarray(d, float)
    theta = np.arctan2(np.hypot(d[..., 0], d[..., 2]), d[..., 1])
    phi = np.mod(np.arctan2(d[..., 0], -d[..., 2]), _TWO_PI)
    return phi / _TWO_PI, theta / np.pi


def latlong_texel_dirs(h, w):
    """Directions of the (h, w) pixel centres → (h, w, 3)."""
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    return latlong_dir(u[None, :], v[:, None])


def latlong_solid_angles(h, w):
    """Exact texel solid angles (h, w): (2π/w)(cos θ_i − cos θ_{i+1}), θ_i = π i / h."""
    c = np.cos(np.pi * np.arange(h + 1) / h)
    row = (_TWO_PI / w) * (c[:-1] - c[1:])
    return np.repeat(row[:, None], w, axis=1)


# --- cubemap (OpenGL order +X, −X, +Y, −Y, +Z, −Z and orientation) ---------------------------
def cubemap_dir(face, s, t):
    """OpenGL cube face + (s, t) ∈ [0,1]² → unit direction (inverse of the spec's sc/tc/ma table)."""
    face = np.asarray(face)
    a = 2.0 * np.asarray(s, float) - 1.0
    b = 2.0 * np.asarray(t, float) - 1.0
    face, a, b = np.broadcast_arrays(face, a, b)
    one = np.ones_like(a)
    cand = np.stack([
        np.stack([one, -b, -a], -1),     # +X: sc = −z, tc = −y
        np.stack([-one, -b, a], -1),     # −X: sc = +z, tc = −y
        np.stack([a, one, b], -1),       # +Y: sc = +x, tc = +z
        np.stack([a, -one, -b], -1),     # −Y: sc = +x, tc = −z
        np.stack([a, -b, one], -1),      # +Z: sc = +x, tc = −y
        np.stack([-a, -b, -one], -1),    # −Z: sc = −x, tc = −y
    ], 0)
    d = np.take_along_axis(cand, face[None, ..., None].astype(int), 0)[0]
    return _unit(d)


def dir_to_cubemap(d):
    """Direction → (face, s, t) following the OpenGL major-axis selection (ties: x > y > z)."""
    d = np.asarray(d, float)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
    xm = (ax >= ay) & (ax >= az)
    ym = ~xm & (ay >= az)
    face = np.where(xm, np.where(x >= 0, 0, 1), np.where(ym, np.where(y >= 0, 2, 3), np.where(z >= 0, 4, 5)))
    sc = np.choose(face, [-z, z, x, x, x, -x])
    tc = np.choose(face, [-y, -y, z, -z, -y, -y])
    ma = np.choose(face, [ax, ax, ay, ay, az, az])
    return face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0)


def cubemap_texel_dirs(res):
    """Texel-centre directions (6, res, res, 3); row index ↔ t, column index ↔ s."""
    c = (np.arange(res) + 0.5) / res
    f = np.arange(6)[:, None, None]
    return cubemap_dir(f, c[None, None, :], c[None, :, None])


def cubemap_face_solid_angles(res):
    """Exact texel solid angles (res, res) of one face (the same on all six) via
    A(x, y) = atan2(xy, sqrt(x² + y² + 1))."""
    e = np.linspace(-1.0, 1.0, res + 1)
    x, y = e[None, :], e[:, None]
    a = np.arctan2(x * y, np.sqrt(x * x + y * y + 1.0))     # A at every texel corner, once
    return a[1:, 1:] - a[1:, :-1] - a[:-1, 1:] + a[:-1, :-1]


def cubemap_solid_angles(res):
    """Exact texel solid angles (6, res, res) (`cubemap_face_solid_angles` on every face)."""
    return np.broadcast_to(cubemap_face_solid_angles(res), (6, res, res)).copy()


# --- dual paraboloid (Heidrich–Seidel, scale b as in Töral19 eq 11 / Colbert–Křivánek) -----
def dual_paraboloid_dir(hemi, s, t, b=1.0):
    """(hemi, s, t) → direction; hemi 0 = front (+Z), 1 = back (−Z); row 0 (t = 0) is +Y.

    Paraboloid coordinates ρ = b (2s − 1, 1 − 2t); front: (x, y, z) = (2ρx, 2ρy, 1 − ρ²)/(1 + ρ²),
    back mirrors x and z. With b > 1 the square also covers directions past the equator.
    """
    hemi = np.asarray(hemi)
    px = b * (2.0 * np.asarray(s, float) - 1.0)
    py = b * (1.0 - 2.0 * np.asarray(t, float))
    hemi, px, py = np.broadcast_arrays(hemi, px, py)
    r2 = px * px + py * py
    inv = 1.0 / (1.0 + r2)
    sgn = np.where(hemi == 0, 1.0, -1.0)
    return np.stack([sgn * 2.0 * px * inv, 2.0 * py * inv, sgn * (1.0 - r2) * inv], axis=-1)


def dir_to_dual_paraboloid(d, b=1.0):
    """Direction → (hemi, s, t): hemi 0 if z >= 0; ρ = (x, y)/(1 + |z|) (x mirrored for back)."""
    d = np.asarray(d, float)
    z = d[..., 2]
    hemi = np.where(z >= 0.0, 0, 1)
    sgn = np.where(hemi == 0, 1.0, -1.0)
    den = 1.0 + np.abs(z)
    px = sgn * d[..., 0] / den
    py = d[..., 1] / den
    return hemi, 0.5 * (px / b + 1.0), 0.5 * (1.0 - py / b)


def dual_paraboloid_distortion(d, b=1.0):
    """Töral19 eq 11: d(i) = 4 b² (|i_z| + 1)², so Ω_texel ≈ d(i)/(w·h) (eq 9)."""
    d = np.asarray(d, float)
    return 4.0 * b * b * (np.abs(d[..., 2]) + 1.0) ** 2


def dual_paraboloid_solid_angles(res, b=1.0):
    """Exact texel solid angles (2, res, res) of ∫∫ 4b²/(1 + b²(x² + y²))² dx dy over each texel.

    Closed form via F(X, Y) = 2[X/√(1+X²) atan(Y/√(1+X²)) + Y/√(1+Y²) atan(X/√(1+Y²))],
    ∂²F/∂X∂Y = 4/(1 + X² + Y²)², X = b x. This is the footprint of the whole texel square;
    texels beyond the map's own hemisphere (b > 1) duplicate the other map, and
    ``dual_paraboloid_valid_mask`` selects those whose centre is inside (they sum to ≈ 4π).
    """
    e = b * np.linspace(-1.0, 1.0, res + 1)

    def F(X, Y):
        a = np.sqrt(1.0 + X * X)
        c = np.sqrt(1.0 + Y * Y)
        return 2.0 * (X / a * np.arctan(Y / a) + Y / c * np.arctan(X / c))

    x0, x1 = e[:-1][None, :], e[1:][None, :]
    y0, y1 = e[:-1][:, None], e[1:][:, None]
    om = F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0)   # symmetric in y: row flip not needed
    return np.broadcast_to(om, (2, res, res)).copy()


def dual_paraboloid_resample(sample, res: int, b: float = 1.0, supersample: int = 2):
    """Dual-paraboloid texels (2, res, res, C) of a spherical function: each the solid-angle
    weighted mean (dω ∝ (1 + ρ²)⁻²) of `supersample`² values `sample(dirs (2, res, res, 3)) →
    (2, res, res, C)` over the texel (Töral19 eq 11 with scale b)."""
    ss = int(supersample)
    off = (np.arange(ss) + 0.5) / ss
    c = np.arange(res)
    acc = 0.0
    wsum = 0.0
    for oa in off:
        for ob in off:
            s = (c[None, None, :] + ob) / res
            t = (c[None, :, None] + oa) / res
            d = dual_paraboloid_dir(np.arange(2)[:, None, None], s, t, b)
            rho2 = (b * (2 * s - 1)) ** 2 + (b * (1 - 2 * t)) ** 2
            w = 1.0 / (1.0 + rho2) ** 2
            acc = acc + sample(d) * w[..., None]
            wsum = wsum + w
    return acc / wsum[..., None]


def dual_paraboloid_texel_dirs(res, b=1.0):
    """Texel-centre directions (2, res, res, 3)."""
    c = (np.arange(res) + 0.5) / res
    return dual_paraboloid_dir(np.arange(2)[:, None, None], c[None, None, :], c[None, :, None], b)


def dual_paraboloid_valid_mask(res, b=1.0):
    """(2, res, res) bool: texel centre lies in the map's own hemisphere (front z >= 0, back z < 0)."""
    d = dual_paraboloid_texel_dirs(res, b)
    return np.stack([d[0, ..., 2] >= 0.0, d[1, ..., 2] < 0.0])


def faces_to_image(faces: np.ndarray) -> np.ndarray:
    """(6, m, m, C) → (6·m, m, C): faces stacked vertically in OpenGL order."""
    f = np.asarray(faces)
    return f.reshape(6 * f.shape[1], f.shape[2], f.shape[3])


def image_to_faces(img: np.ndarray) -> np.ndarray:
    """(6·m, m, C) → (6, m, m, C)."""
    img = np.asarray(img)
    m = img.shape[1]
    if img.shape[0] != 6 * m:
        raise ValueError(f"not a vertical cube strip: shape {img.shape}")
    return img.reshape(6, m, m, img.shape[2])


def bordered_box_level(faces: np.ndarray, dtype=None, zero=None) -> np.ndarray:
    """(6, n, n, C) → (6·(n+2), n+2, C): a 1-texel border per face holding the neighbouring
    face bilinearly sampled (clamped inside that face) at the border texel's extended-plane
    direction, so per-face bilinear fetches agree across seams to second order. `dtype`
    (default the input's) and `zero` (a (6, n, n) mask of texels set to 0 first) spare the
    caller a converted or masked copy of the faces."""
    faces = np.asarray(faces)
    n = faces.shape[1]
    m = n + 2
    out = np.zeros((6, m, m, faces.shape[3]), dtype or faces.dtype)
    out[:, 1:-1, 1:-1] = faces
    if zero is not None:
        out[:, 1:-1, 1:-1][zero] = 0.0
    faces = out[:, 1:-1, 1:-1]
    ring = np.zeros((m, m), bool)
    ring[0, :] = ring[-1, :] = ring[:, 0] = ring[:, -1] = True
    ii, jj = np.nonzero(ring)
    for f in range(6):
        d = cubemap_dir(f, (jj - 0.5) / n, (ii - 0.5) / n)
        g, s, t = dir_to_cubemap(d)
        u = np.clip(s * n - 0.5, 0, n - 1)
        v = np.clip(t * n - 0.5, 0, n - 1)
        j0 = np.minimum(np.floor(u).astype(int), max(n - 2, 0))
        i0 = np.minimum(np.floor(v).astype(int), max(n - 2, 0))
        j1 = np.minimum(j0 + 1, n - 1)
        i1 = np.minimum(i0 + 1, n - 1)
        fu = (u - j0)[:, None]
        fv = (v - i0)[:, None]
        out[f, ii, jj] = ((1 - fv) * ((1 - fu) * faces[g, i0, j0] + fu * faces[g, i0, j1])
                          + fv * ((1 - fu) * faces[g, i1, j0] + fu * faces[g, i1, j1]))
    return faces_to_image(out)


def solid_angle_box_chain(maps: np.ndarray, omega: np.ndarray) -> list[np.ndarray]:
    """Box MIP chain of K square maps (K, n, n, C) with texel solid angles omega (K, n, n), for
    n = N, N/2, … while even: each parent is the solid-angle-weighted mean of its 2×2 children
    (so ∫L dω is preserved at every level)."""
    maps = np.asarray(maps, np.float64)
    chain = [maps]
    om = np.asarray(omega, np.float64)
    k = maps.shape[0]
    while chain[-1].shape[1] > 1 and chain[-1].shape[1] % 2 == 0:
        f = chain[-1]
        n = f.shape[1] // 2
        e = (f * om[..., None]).reshape(k, n, 2, n, 2, -1).sum(axis=(2, 4))
        om = om.reshape(k, n, 2, n, 2).sum(axis=(2, 4))
        chain.append(e / om[..., None])
    return chain


def cube_mip_chain(faces: np.ndarray) -> list[np.ndarray]:
    """Box MIP chain (6, n, n, C) for n = N, N/2, …, 1 of a cubemap (solid_angle_box_chain)."""
    return solid_angle_box_chain(faces, cubemap_solid_angles(np.shape(faces)[1]))
