"""Compiled objective of the free-axis SG least-squares fit (Wang09 §4.2, L-BFGS-B)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def sg_l2_objective(h, weights, values, axis, lam, mu, grad_axis, grad_loglam, grad_logmu):
    """Σ w (Σ_l μ_l e^{λ_l(h·p_l − 1)} − D)² and its gradient w.r.t. p_l (unconstrained 3-D),
    log λ_l and log μ_l (written into the grad_* arrays)."""
    n = h.shape[0]
    k_n = axis.shape[0]
    e = np.empty(k_n)
    dots = np.empty(k_n)
    grad_axis[:, :] = 0.0
    grad_loglam[:] = 0.0
    grad_logmu[:] = 0.0
    f = 0.0
    for s in range(n):
        x0 = h[s, 0]
        x1 = h[s, 1]
        x2 = h[s, 2]
        g = 0.0
        for k in range(k_n):
            d = axis[k, 0] * x0 + axis[k, 1] * x1 + axis[k, 2] * x2
            dots[k] = d
            v = math.exp(lam[k] * (d - 1.0)) * mu[k]
            e[k] = v
            g += v
        r = g - values[s]
        wr = weights[s] * r
        f += wr * r
        for k in range(k_n):
            c = 2.0 * wr * e[k]
            grad_logmu[k] += c
            grad_loglam[k] += c * lam[k] * (dots[k] - 1.0)
            cl = c * lam[k]
            grad_axis[k, 0] += cl * x0
            grad_axis[k, 1] += cl * x1
            grad_axis[k, 2] += cl * x2
    return f
