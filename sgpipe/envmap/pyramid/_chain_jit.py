"""Compiled quadrature masses of a chained Γ_L level's source (`chain.chain_source`)."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from sgpipe.envmap.pyramid._masses_jit import CX, CY, CZ, E0, NCOMP


@njit(cache=True, inline="always")
def _step5(y):
    """C⁵ step 0 → 1 on [0, 1] with S(y) + S(1 − y) = 1 (S' ∝ y⁵(1 − y)⁵)."""
    y = min(max(y, 0.0), 1.0)
    return y ** 6 * (462.0 + y * (-1980.0 + y * (3465.0 + y * (-3080.0 + y * (
        1386.0 - 252.0 * y)))))


def chain_source_shape(n, pad, step):
    """Shape of `chain_source`'s row blocks."""
    m = (n + 2 * pad + step - 1) // step
    return (6, m, NCOMP, m)


@njit(cache=True, parallel=True)
def chain_source(acc, n, ext, norm, pad, blend, uva, step, out):
    """Masses of a level's V = acc[..., 0:3]/norm at every `step`-th of its texel centres
    extended `pad` texels beyond each face (row blocks (6, m, NCOMP, m), m = ⌈(n + 2·pad)/step⌉,
    centres at c0 + i·step·h, c0 = −1 + (½ − pad)·h, h = 2/n), weighted for the quadrature
    of smooth integrands over S²: the midpoint rule in face coordinates (J·h²) times the face's
    share φ_f of a smooth partition of unity (C⁵ steps of half-width `blend` texels across every
    face edge, normalised over the faces), into `out` (zeros, `chain_source_shape`). See
    `chain.chain_source`."""
    m = (n + 2 * pad + step - 1) // step
    h = 2.0 / n
    d = 2.0 * blend * h
    hh = (step * h) ** 2 / norm
    for job in prange(6 * m):
        f = job // m
        i = job % m
        t = (step * i - pad + 0.5) * h - 1.0
        for j in range(m):
            s = (step * j - pad + 0.5) * h - 1.0
            x = s * uva[f, 0, 0] + t * uva[f, 1, 0] + uva[f, 2, 0]
            y = s * uva[f, 0, 1] + t * uva[f, 1, 1] + uva[f, 2, 1]
            z = s * uva[f, 0, 2] + t * uva[f, 1, 2] + uva[f, 2, 2]
            q = x * x + y * y + z * z           # = 1 + s² + t² (an orthonormal frame)
            ir = 1.0 / np.sqrt(q)
            x *= ir
            y *= ir
            z *= ir
            total = 1.0
            own = 1.0
            if abs(s) > 1.0 - 0.5 * d or abs(t) > 1.0 - 0.5 * d:    # in a blend: φ_f < 1
                total = 0.0
                own = 0.0
            for g in range(6 if total == 0.0 else 0):
                a = x * uva[g, 2, 0] + y * uva[g, 2, 1] + z * uva[g, 2, 2]
                if a <= 1e-9:
                    continue
                sg = (x * uva[g, 0, 0] + y * uva[g, 0, 1] + z * uva[g, 0, 2]) / a
                tg = (x * uva[g, 1, 0] + y * uva[g, 1, 1] + z * uva[g, 1, 2]) / a
                ps = (_step5((1.0 + 0.5 * d - abs(sg)) / d)
                      * _step5((1.0 + 0.5 * d - abs(tg)) / d))
                total += ps
                if g == f:
                    own = ps
            w = own / total * (ir * ir * ir) * hh if total > 0 else 0.0
            out[f, i, CX, j] = x
            out[f, i, CY, j] = y
            out[f, i, CZ, j] = z
            for c in range(3):
                out[f, i, E0 + c, j] = acc[f, ext - pad + step * i, ext - pad + step * j, c] * w
    return out
