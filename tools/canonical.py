"""Arithmetic whose result does not depend on the CPU, for the sample generators.

numpy's matmul/einsum go through BLAS or SIMD kernels whose summation order and FMA use depend
on the processor, so their last bits (and the sign of a zero) vary between machines. These
helpers use only elementwise +, −, ×, ÷ and √ in a fixed order (IEEE-754 correctly rounded, the
same on every x86-64 and arm64 CPU) and math.fsum (exactly rounded, so independent of order).
Transcendental functions (sin, cos, exp) may still differ by an ulp between CPUs; the written
values are rounded far coarser than that, and the tests check that no written value lies close
enough to a rounding boundary for an ulp to move it.
"""

from __future__ import annotations

import math

import numpy as np


def dot3(a: np.ndarray, b) -> np.ndarray:
    """a · b over the last axis (length 3), summed left to right."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], -1)


def norm3(a: np.ndarray) -> np.ndarray:
    """Euclidean length over the last axis (length 3)."""
    return np.sqrt(dot3(a, a))


def normalize3(a: np.ndarray) -> np.ndarray:
    """a / |a| over the last axis."""
    return np.asarray(a, np.float64) / norm3(a)[..., None]


def fsum_channels(img: np.ndarray) -> np.ndarray:
    """Exactly rounded sum over every axis but the last: (..., C) → (C,)."""
    flat = np.asarray(img, np.float64).reshape(-1, np.shape(img)[-1])
    return np.array([math.fsum(flat[:, c]) for c in range(flat.shape[1])])


def decimals(x, nd: int = 6) -> np.ndarray:
    """x rounded to nd decimals with negative zeros made positive (−0.0 + 0.0 = +0.0)."""
    return np.round(np.asarray(x, np.float64), nd) + 0.0
