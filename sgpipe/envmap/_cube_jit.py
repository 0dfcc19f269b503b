"""Compiled cubemap helpers shared by the pyramid, MIP chain and conversions (numba cores).

Faces follow the OpenGL table (docs/CONVENTIONS.md): face f has major axis A_f and the face coordinates
sc = v·U_f / v·A_f, tc = v·V_f / v·A_f with the (U, V, A) rows below.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

# (U, V, A) per face: sc = v·U/ma, tc = v·V/ma, ma = v·A  (OpenGL cube-map table)
FACE_UVA = np.array([
    [[0, 0, -1], [0, -1, 0], [1, 0, 0]],     # +X: sc = −z, tc = −y
    [[0, 0, 1], [0, -1, 0], [-1, 0, 0]],     # −X: sc = +z, tc = −y
    [[1, 0, 0], [0, 0, 1], [0, 1, 0]],       # +Y: sc = +x, tc = +z
    [[1, 0, 0], [0, 0, -1], [0, -1, 0]],     # −Y: sc = +x, tc = −z
    [[1, 0, 0], [0, -1, 0], [0, 0, 1]],      # +Z: sc = +x, tc = −y
    [[-1, 0, 0], [0, -1, 0], [0, 0, -1]],    # −Z: sc = −x, tc = −y
], dtype=np.float64)


@njit(cache=True)
def face_of(x, y, z):
    """OpenGL major-axis face (ties: x before y before z)."""
    ax, ay, az = abs(x), abs(y), abs(z)
    if ax >= ay and ax >= az:
        return 0 if x >= 0 else 1
    if ay >= az:
        return 2 if y >= 0 else 3
    return 4 if z >= 0 else 5


@njit(cache=True)
def face_st(uva, f, x, y, z):
    """Face coordinates (s, t) ∈ [0, 1] of a direction on face f (extended plane outside)."""
    ma = x * uva[f, 2, 0] + y * uva[f, 2, 1] + z * uva[f, 2, 2]
    sc = (x * uva[f, 0, 0] + y * uva[f, 0, 1] + z * uva[f, 0, 2]) / ma
    tc = (x * uva[f, 1, 0] + y * uva[f, 1, 1] + z * uva[f, 1, 2]) / ma
    return 0.5 * (sc + 1.0), 0.5 * (tc + 1.0)


@njit(cache=True)
def face_dir(uva, f, s, t):
    """Unit direction of face coordinates (s, t) on face f (any s, t: extended plane)."""
    sc = 2.0 * s - 1.0
    tc = 2.0 * t - 1.0
    x = sc * uva[f, 0, 0] + tc * uva[f, 1, 0] + uva[f, 2, 0]
    y = sc * uva[f, 0, 1] + tc * uva[f, 1, 1] + uva[f, 2, 1]
    z = sc * uva[f, 0, 2] + tc * uva[f, 1, 2] + uva[f, 2, 2]
    n = np.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n


@njit(cache=True)
def bspline_weights(t, w):
    """Uniform cubic B-spline weights for taps −1, 0, 1, 2 at fraction t ∈ [0, 1)."""
    t2 = t * t
    t3 = t2 * t
    u = 1.0 - t
    w[0] = u * u * u / 6.0
    w[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0
    w[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0
    w[3] = t3 / 6.0


@njit(cache=True, parallel=False)
def sample_bordered(img, n, border, dirs, cubic, out):
    """Sample a bordered cubemap (6·(n+2b), n+2b, C) at unit directions (M, 3) → out (M, C).

    cubic: uniform cubic B-spline on stored coefficients (needs border >= 2); else bilinear on
    stored values (border >= 1). Never reads outside the direction's own bordered face.
    """
    m = n + 2 * border
    C = img.shape[2]
    w_s = np.empty(4)
    w_t = np.empty(4)
    for k in range(dirs.shape[0]):
        x, y, z = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        f = face_of(x, y, z)
        s, t = face_st(FACE_UVA, f, x, y, z)
        u = s * n + border - 0.5
        v = t * n + border - 0.5
        j0 = int(np.floor(u))
        i0 = int(np.floor(v))
        fu = u - j0
        fv = v - i0
        base = f * m
        for c in range(C):
            out[k, c] = 0.0
        if cubic:
            bspline_weights(fu, w_s)
            bspline_weights(fv, w_t)
            for a in range(4):
                ii = min(max(i0 - 1 + a, 0), m - 1)
                for b in range(4):
                    jj = min(max(j0 - 1 + b, 0), m - 1)
                    w = w_t[a] * w_s[b]
                    for c in range(C):
                        out[k, c] += w * img[base + ii, jj, c]
        else:
            for a in range(2):
                ii = min(max(i0 + a, 0), m - 1)
                wa = fv if a == 1 else 1.0 - fv
                for b in range(2):
                    jj = min(max(j0 + b, 0), m - 1)
                    w = wa * (fu if b == 1 else 1.0 - fu)
                    for c in range(C):
                        out[k, c] += w * img[base + ii, jj, c]
    return out


@njit(cache=True)
def latlong_bilinear(img, x, y, z, out):
    """Bilinear lat-long sample (CONVENTIONS mapping) with φ wrap-around and reflection across the
    poles (a row 'above' row 0 is row 0 seen from φ + π), so seams and poles are continuous."""
    H, W, C = img.shape
    theta = np.arctan2(np.sqrt(x * x + z * z), y)
    phi = np.arctan2(x, -z)
    if phi < 0.0:
        phi += 2.0 * np.pi
    u = phi / (2.0 * np.pi) * W - 0.5
    v = theta / np.pi * H - 0.5
    i0 = int(np.floor(v))
    j0 = int(np.floor(u))
    fv = v - i0
    fu = u - j0
    for c in range(C):
        out[c] = 0.0
    for a in range(2):
        ii = i0 + a
        shift = 0
        if ii < 0:
            ii = -ii - 1
            shift = W // 2
        elif ii >= H:
            ii = 2 * H - ii - 1
            shift = W // 2
        wa = fv if a == 1 else 1.0 - fv
        for b in range(2):
            jj = (j0 + b + shift) % W
            w = wa * (fu if b == 1 else 1.0 - fu)
            for c in range(C):
                out[c] += w * img[ii, jj, c]


@njit(cache=True, parallel=True)
def latlong_to_cube_jit(img, n, ss):
    """Cube faces (6, n, n, C): solid-angle-weighted average of ss×ss bilinear sub-samples."""
    C = img.shape[2]
    out = np.zeros((6, n, n, C))
    for job in prange(6 * n):
        f = job // n
        i = job % n
        tmp = np.empty(C)
        for j in range(n):
            wsum = 0.0
            for a in range(ss):
                for b in range(ss):
                    s = (j + (b + 0.5) / ss) / n
                    t = (i + (a + 0.5) / ss) / n
                    sc = 2.0 * s - 1.0
                    tc = 2.0 * t - 1.0
                    r2 = 1.0 + sc * sc + tc * tc
                    w = 1.0 / (r2 * np.sqrt(r2))       # dω/dA on the face plane
                    x, y, z = face_dir(FACE_UVA, f, s, t)
                    latlong_bilinear(img, x, y, z, tmp)
                    for c in range(C):
                        out[f, i, j, c] += w * tmp[c]
                    wsum += w
            for c in range(C):
                out[f, i, j, c] /= wsum
    return out


@njit(cache=True, parallel=True)
def sample_dirs_bordered(img, n, border, dirs, cubic):
    """Parallel wrapper of `sample_bordered` over direction chunks."""
    M = dirs.shape[0]
    out = np.empty((M, img.shape[2]))
    nchunk = 64
    step = (M + nchunk - 1) // nchunk
    for k in prange(nchunk):
        lo = k * step
        hi = min(M, lo + step)
        if lo < hi:
            sample_bordered(img, n, border, dirs[lo:hi], cubic, out[lo:hi])
    return out


@njit(cache=True, parallel=True)
def cube_texel_dirs_jit(n):
    """Texel-centre directions (6, n, n, 3) (same as core.maps.cubemap_texel_dirs, compiled)."""
    out = np.empty((6, n, n, 3))
    for job in prange(6 * n):
        f = job // n
        i = job % n
        for j in range(n):
            x, y, z = face_dir(FACE_UVA, f, (j + 0.5) / n, (i + 0.5) / n)
            out[f, i, j, 0] = x
            out[f, i, j, 1] = y
            out[f, i, j, 2] = z
    return out
