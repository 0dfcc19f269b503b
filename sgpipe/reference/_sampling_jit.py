"""Compiled core of the Monte Carlo reference (contract: sgpipe.reference).

* Counter-based RNG: u(seed, pixel, sample, dim) = splitmix64 hash → [0, 1) with 53 bits, so
  a pixel's random numbers do not depend on tiles, passes or worker count.
* Environment importance sampling (piecewise constant over lat-long texels): texel (i, j) is
  drawn with probability P_ij = Y_ij Ω_i / Z, Z = Σ Y Ω, Ω_i = (2π/W)(cos θ_i − cos θ_{i+1})
  (the sin θ Jacobian integrated exactly over the texel); inside the texel the direction is
  uniform in (φ, cos θ), i.e. uniform in solid angle, so the solid-angle pdf is exactly
  p(ω) = Y_ij / Z — proportional to the (nearest-texel) radiance's luminance.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_TWO_PI = 2.0 * np.pi
_INV_2_53 = 1.0 / 9007199254740992.0


@njit(cache=True, inline="always")
def _splitmix64(x):
    x = (x + np.uint64(0x9E3779B97F4A7C15))
    z = x
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def uniforms(seed, pixel_ids, s0, ns, nd):
    """(P, ns, nd) uniforms in [0, 1) for samples s0 .. s0+ns−1 of the given global pixel ids."""
    out = np.empty((pixel_ids.shape[0], ns, nd))
    ks = _splitmix64(np.uint64(seed) ^ np.uint64(0x5EED5EED5EED5EED))
    for p in range(pixel_ids.shape[0]):
        kp = _splitmix64(ks ^ np.uint64(pixel_ids[p]))
        for s in range(ns):
            kss = _splitmix64(kp ^ np.uint64(s0 + s) * np.uint64(0xD1B54A32D192ED03))
            for d in range(nd):
                h = _splitmix64(kss + np.uint64(d) * np.uint64(0x632BE59BD9B4E019))
                out[p, s, d] = np.float64(h >> np.uint64(11)) * _INV_2_53
    return out


@njit(cache=True)
def build_distribution(lum):
    """Row CDF (H+1), per-row column CDFs (H, W+1), cos θ edges (H+1) and Z = Σ Y Ω."""
    h, w = lum.shape
    cos_edge = np.empty(h + 1)
    for i in range(h + 1):
        cos_edge[i] = np.cos(np.pi * i / h)
    cos_edge[0] = 1.0
    cos_edge[h] = -1.0
    row_cdf = np.zeros(h + 1)
    col_cdf = np.zeros((h, w + 1))
    for i in range(h):
        acc = 0.0
        for j in range(w):
            acc += lum[i, j]
            col_cdf[i, j + 1] = acc
        if acc > 0:
            for j in range(1, w + 1):
                col_cdf[i, j] /= acc
        else:  # never drawn (zero row weight); keep a valid uniform CDF
            for j in range(1, w + 1):
                col_cdf[i, j] = j / w
        col_cdf[i, w] = 1.0
        omega = _TWO_PI / w * (cos_edge[i] - cos_edge[i + 1])
        row_cdf[i + 1] = row_cdf[i] + acc * omega
    z = row_cdf[h]
    if z > 0:
        for i in range(1, h + 1):
            row_cdf[i] /= z
        row_cdf[h] = 1.0
    return row_cdf, col_cdf, cos_edge, z


@njit(cache=True, inline="always")
def _search(cdf, n, u):
    """Largest k in [0, n) with cdf[k] <= u (skips empty bins: cdf[k+1] > u)."""
    lo, hi = 0, n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if cdf[mid] <= u:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def sample_env(u1, u2, row_cdf, col_cdf, cos_edge, lum, rgb, z):
    """Directions (N, 3), solid-angle pdf (N,) and radiance (N, 3) of env samples."""
    n = u1.shape[0]
    h, w = lum.shape
    dirs = np.empty((n, 3))
    pdf = np.zeros(n)
    rad = np.zeros((n, 3))
    for k in range(n):
        i = _search(row_cdf, h, u1[k])
        du = row_cdf[i + 1] - row_cdf[i]
        r1 = (u1[k] - row_cdf[i]) / du if du > 0 else 0.5
        j = _search(col_cdf[i], w, u2[k])
        dv = col_cdf[i, j + 1] - col_cdf[i, j]
        r2 = (u2[k] - col_cdf[i, j]) / dv if dv > 0 else 0.5
        r1 = min(max(r1, 0.0), 1.0)
        r2 = min(max(r2, 0.0), 1.0)
        c = cos_edge[i] - r1 * (cos_edge[i] - cos_edge[i + 1])
        s = np.sqrt(max(0.0, 1.0 - c * c))
        phi = _TWO_PI * (j + r2) / w
        dirs[k, 0] = s * np.sin(phi)
        dirs[k, 1] = c
        dirs[k, 2] = -s * np.cos(phi)
        if z > 0:
            pdf[k] = lum[i, j] / z
        for ch in range(3):
            rad[k, ch] = rgb[i, j, ch]
    return dirs, pdf, rad


@njit(cache=True)
def lookup_env(dirs, lum, rgb, z):
    """Nearest-texel radiance (N, 3) and env-sampling pdf (N,) of world directions (N, 3)."""
    n = dirs.shape[0]
    h, w = lum.shape
    rad = np.empty((n, 3))
    pdf = np.zeros(n)
    for k in range(n):
        x, y, zz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        theta = np.arctan2(np.sqrt(x * x + zz * zz), y)
        phi = np.arctan2(x, -zz)
        if phi < 0:
            phi += _TWO_PI
        j = int(phi / _TWO_PI * w)
        i = int(theta / np.pi * h)
        j = min(max(j, 0), w - 1)
        i = min(max(i, 0), h - 1)
        for ch in range(3):
            rad[k, ch] = rgb[i, j, ch]
        if z > 0:
            pdf[k] = lum[i, j] / z
    return rad, pdf


@njit(cache=True)
def accumulate(est, n_pix, n_s, out_sum, out_sq):
    """Add per-sample estimates (n_pix*n_s, 3) into per-pixel sums and sums of squares."""
    for p in range(n_pix):
        for s in range(n_s):
            k = p * n_s + s
            for ch in range(3):
                v = est[k, ch]
                out_sum[p, ch] += v
                out_sq[p, ch] += v * v


@njit(cache=True)
def tex_bilinear(img, uv):
    """Bilinear texture lookup (N, C) at uv (N, 2), as the kernels' tex_bilinear (shading.h):
    OBJ uv (v = 0 is the bottom row), texel centres at half-integers, repeat addressing."""
    h, w, c = img.shape
    n = uv.shape[0]
    out = np.empty((n, c))
    for k in range(n):
        x = (uv[k, 0] - np.floor(uv[k, 0])) * w - 0.5
        y = (1.0 - (uv[k, 1] - np.floor(uv[k, 1]))) * h - 0.5
        x0f = np.floor(x)
        y0f = np.floor(y)
        fx = x - x0f
        fy = y - y0f
        x0 = (int(x0f) % w + w) % w
        y0 = (int(y0f) % h + h) % h
        x1 = (x0 + 1) % w
        y1 = (y0 + 1) % h
        for ch in range(c):
            a = img[y0, x0, ch] + fx * (img[y0, x1, ch] - img[y0, x0, ch])
            b = img[y1, x0, ch] + fx * (img[y1, x1, ch] - img[y1, x0, ch])
            out[k, ch] = a + fy * (b - a)
    return out
