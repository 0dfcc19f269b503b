"""Compiled Legendre series of the chained levels' zonal kernels (`kernels`)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def legendre_series(coef, x):
    """Σ_l (2l+1)/(4π) coef[l] P_l(x) at each x (three-term recurrence; the nodes in
    parallel)."""
    out = np.empty((coef.shape[0], x.shape[0]))
    for m in prange(x.shape[0]):
        xm = x[m]
        for c in range(coef.shape[0]):
            p0 = 1.0
            p1 = xm
            s = coef[c, 0] + 3.0 * coef[c, 1] * p1
            for l in range(1, coef.shape[1] - 1):
                p2 = ((2 * l + 1) * xm * p1 - l * p0) / (l + 1)
                s += (2 * l + 3) * coef[c, l + 1] * p2
                p0 = p1
                p1 = p2
            out[c, m] = s / (4.0 * math.pi)
    return out
