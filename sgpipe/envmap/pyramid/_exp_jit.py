"""Branch-free float32 exponentials of the Γ_L pyramid's gathers (compiled, inlined into their
callers' vector loops)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

_EXP_MIN = -60.0
_F0 = np.float32(0.0)
_FMIN = np.float32(_EXP_MIN)
_F64TH = np.float32(0.015625)
_FC = tuple(np.float32(1.0 / math.factorial(k)) for k in range(11))
_FM1 = np.float32(-1.0)


@njit(cache=True, fastmath=True, inline="always")
def _pow32(r):
    """r³² by five squarings (the Taylor polynomials' range reduction undone)."""
    r = r * r
    r = r * r
    r = r * r
    r = r * r
    return r * r


@njit(cache=True, fastmath=True, inline="always")
def fast_exp32(x):
    """e^x for x in [−60, 0] (clamped), float32 (8 lanes per AVX2 register): degree-10 Taylor
    of e^{x/64}, squared six times. Relative error < 1e-5 (float32 rounding, amplified by the
    squarings; Horner's form: Estrin's, as in `exp32_scaled`, rounds to 1.3e-5); branch-free
    so the gather loop vectorises."""
    x = min(max(x, _FMIN), _F0) * _F64TH
    y = _FC[0] + x * (_FC[1] + x * (_FC[2] + x * (_FC[3] + x * (_FC[4] + x * (
        _FC[5] + x * (_FC[6] + x * (_FC[7] + x * (_FC[8] + x * (_FC[9] + x * _FC[10])))))))))
    y = _pow32(y)
    return y * y


@njit(cache=True, fastmath=True, inline="always")
def exp32_scaled(y):
    """e^{32y} for y in [−1, 0] (clamped below), float32: degree-7 Taylor of e^y in Estrin's
    form (powers y², y⁴ beside the pairs: the rows' inner loops are bound by the latency of one
    lane's chain, not by their operation count, and Estrin's chain is half as long as
    Horner's), squared five times. Relative error ≤ 5e-6 for 32y ≥ −12 (float32
    rounding, as `fast_exp32`), 2.5e-4 at −25, 2e-3 at −32 (weights ≤ 1e-10 there). Callers fold
    the 1/32 into the coefficients of the exponent's polynomial (one multiplication less on
    the chain)."""
    x = max(y, _FM1)
    x2 = x * x
    x4 = x2 * x2
    r = (((_FC[0] + x * _FC[1]) + x2 * (_FC[2] + x * _FC[3]))
         + x4 * ((_FC[4] + x * _FC[5]) + x2 * (_FC[6] + x * _FC[7])))
    return _pow32(r)


@njit(cache=True, fastmath=True, inline="always")
def quartic_exponent(z, c1, c2, c3, c4):
    """z(c1 + c2 z + c3 z² + c4 z³), written in Estrin's form for a short dependency chain (the
    rows' inner loops are bound by one lane's exponent → exp → accumulation chain, not by their
    operation count); fastmath lets LLVM reassociate it, and in pass 1's `_sample` it emits
    Horner's."""
    return z * ((c1 + z * c2) + (z * z) * (c3 + z * c4))
