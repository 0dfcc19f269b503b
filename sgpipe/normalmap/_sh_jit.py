"""Compiled level 0 of the SH NDF pyramid: γ_lm = Y_lm(n) per texel (Han07 §5.1), the real SH
of sgpipe.core.sh (same recurrence, normalisation and index order), rows in parallel."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


def sh_norms(lmax: int) -> np.ndarray:
    """K_lm = √((2l+1)/(4π) (l−m)!/(l+m)!) as (lmax+1, lmax+1) [l, m], ×√2 for m > 0."""
    k = np.zeros((lmax + 1, lmax + 1))
    for l in range(lmax + 1):
        for m in range(l + 1):
            k[l, m] = math.sqrt((2 * l + 1) / (4 * math.pi) * math.factorial(l - m)
                                / math.factorial(l + m)) * (math.sqrt(2.0) if m else 1.0)
    return k


@njit(cache=True, parallel=True)
def sh_eval_map(normals, lmax, norms, out):
    """out[i, j, l(l+1)+m] = Y_lm(normals[i, j]) (associated Legendre recurrence in z, (x + iy)^m
    for the azimuth: exact at the poles, as core.sh.sh_eval)."""
    h, w = normals.shape[0], normals.shape[1]
    for i in prange(h):
        p = np.empty(lmax + 1)
        for j in range(w):
            x, y, z = normals[i, j, 0], normals[i, j, 1], normals[i, j, 2]
            cm, sm = 1.0, 0.0
            pmm = 1.0
            for m in range(lmax + 1):
                if m > 0:
                    cm, sm = cm * x - sm * y, cm * y + sm * x
                    pmm = pmm * (2 * m - 1)
                for l in range(m, lmax + 1):
                    if l == m:
                        p[l] = pmm
                    elif l == m + 1:
                        p[l] = z * (2 * m + 1) * pmm
                    else:
                        p[l] = ((2 * l - 1) * z * p[l - 1] - (l + m - 1) * p[l - 2]) / (l - m)
                    k = norms[l, m] * p[l]
                    if m == 0:
                        out[i, j, l * (l + 1)] = k
                    else:
                        out[i, j, l * (l + 1) + m] = k * cm
                        out[i, j, l * (l + 1) - m] = k * sm


@njit(cache=True, parallel=True)
def box_down_map(a, out):
    """out = the mean of each 2×2 block of a (h, w, C), in pyramid.box_down's summation order."""
    h, w, c = out.shape
    for i in prange(h):
        for j in range(w):
            for k in range(c):
                out[i, j, k] = 0.25 * ((a[2 * i, 2 * j, k] + a[2 * i, 2 * j + 1, k])
                                       + (a[2 * i + 1, 2 * j, k] + a[2 * i + 1, 2 * j + 1, k]))
