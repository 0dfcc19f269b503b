"""Compiled finish of a Γ_L pyramid level: V = Γ/S, the log-slope m, and their cubic B-spline
coefficients (docs/ARTIFACTS.md, `envmap/`)."""
from __future__ import annotations

import math

import numpy as np
from numba import get_thread_id, njit, prange

_Z = math.sqrt(3.0) - 2.0          # pole of the cubic B-spline prefilter


@njit(cache=True, parallel=True)
def finish_level(acc, lam, norm, extra, values, slopes, plain, scratch):
    """From the gathered Γ, ∂Γ/∂λ (6, m, m, 6): V = Γ/S(λ), m = λ Γ'/Γ, then cubic B-spline
    coefficients per face and channel (rows, then columns), cropped by `extra` into the
    (6·w, w, 3) float32 images `values` and `slopes` (w = m − 2·extra); `plain` (6·(w−2), w−2, 3)
    receives the V samples themselves with a 1-texel border. One job per face and quantity,
    three channels at once (the accumulator is read twice, the images written contiguously);
    each thread works in its own row of `scratch` (float64, ≥ 3·m² per thread: the caller's,
    reused from level to level)."""
    m = acc.shape[1]
    w = m - 2 * extra
    wp = w - 2
    for job in prange(12):
        f = job // 2
        slope = job % 2 == 1
        buf = scratch[get_thread_id(), :3 * m * m].reshape((m, 3 * m))
        for i in range(m):
            for j in range(m):
                for c in range(3):
                    g = acc[f, i, j, c]
                    if slope:
                        buf[i, 3 * j + c] = lam * acc[f, i, j, c + 3] / g if g > 0.0 else 0.0
                    else:
                        buf[i, 3 * j + c] = g / norm
        if not slope:
            for i in range(wp):
                for j in range(wp):
                    for c in range(3):
                        plain[f * wp + i, j, c] = buf[i + extra + 1, 3 * (j + extra + 1) + c]
        prefilter_rows(buf)                 # along i (vectorised over j and the channels)
        _prefilter_interleaved(buf, 3)      # along j, row by row (a transpose costs more)
        img = slopes if slope else values
        for i in range(extra, m - extra):
            for j in range(extra, m - extra):
                for c in range(3):
                    img[f * w + i - extra, j - extra, c] = buf[i, 3 * j + c]


@njit(cache=True)
def prefilter_rows(b):
    """In-place cubic B-spline interpolation prefilter (mirror boundary, Unser: gain 6, causal
    and anti-causal recursions with pole z = √3 − 2) along axis 0 of b (m, k), for all k columns
    at once so the inner loops run over contiguous rows."""
    z = _Z
    n, k_cols = b.shape
    horizon = min(n, 30)
    s = np.zeros(k_cols)
    zk = 1.0
    for k in range(horizon):
        for j in range(k_cols):
            s[j] += zk * b[k, j]
        zk *= z
    for j in range(k_cols):
        b[0, j] = 6.0 * s[j]
    for k in range(1, n):
        for j in range(k_cols):
            b[k, j] = 6.0 * b[k, j] + z * b[k - 1, j]
    c = z / (z * z - 1.0)
    for j in range(k_cols):
        b[n - 1, j] = c * (b[n - 1, j] + z * b[n - 2, j])
    for k in range(n - 2, -1, -1):
        for j in range(k_cols):
            b[k, j] = z * (b[k + 1, j] - b[k, j])


@njit(cache=True)
def _prefilter_interleaved(b, nc):
    """`prefilter_rows` along axis 1 of b (r, m·nc) holding m samples of nc interleaved
    channels per row: the same recursions, one row at a time."""
    z = _Z
    r = b.shape[0]
    n = b.shape[1] // nc
    horizon = min(n, 30)
    c_end = z / (z * z - 1.0)
    for i in range(r):
        row = b[i]
        for c in range(nc):
            s = 0.0
            zk = 1.0
            for k in range(horizon):
                s += zk * row[k * nc + c]
                zk *= z
            row[c] = 6.0 * s
        for k in range(1, n):
            for c in range(nc):
                row[k * nc + c] = 6.0 * row[k * nc + c] + z * row[(k - 1) * nc + c]
        for c in range(nc):
            row[(n - 1) * nc + c] = c_end * (row[(n - 1) * nc + c] + z * row[(n - 2) * nc + c])
        for k in range(n - 2, -1, -1):
            for c in range(nc):
                row[k * nc + c] = z * (row[(k + 1) * nc + c] - row[k * nc + c])
