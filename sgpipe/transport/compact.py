"""Compact storage of the fitted Gaussians (Green06 §6.1 stores 92 × 7 float32 per Gaussian per
vertex): octahedral unit directions in 2 × uint16, σ as an 8-bit log code, RGB weights as half
floats (scaled by one float32 per vertex), and only the views the renderer can reach — views
with a nonzero weight and their neighbours (needed to interpolate towards the horizon); colour
only for the weighted views.
Per vertex two 92-bit masks say which views are stored and which carry colour."""

from __future__ import annotations

import numpy as np

from sgpipe.artifacts.transport import (  # noqa: F401  (decode: the artifact's reader)
    decode_gaussians as decode, oct_decode, read_gaussians, sigma_decode)
from sgpipe.transport.views import N_VIEWS, view_set

MASK_BYTES = (N_VIEWS + 7) // 8
HALF_MAX = float(np.finfo(np.float16).max)


def oct_encode(d):
    """Unit directions (..., 3) → octahedral (..., 2) uint16 (Meyer et al. 2010)."""
    d = np.asarray(d, float)
    p = d / np.maximum(np.abs(d).sum(-1, keepdims=True), 1e-300)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    sx, sy = np.where(x >= 0, 1.0, -1.0), np.where(y >= 0, 1.0, -1.0)
    ox = np.where(z < 0, (1 - np.abs(y)) * sx, x)
    oy = np.where(z < 0, (1 - np.abs(x)) * sy, y)
    q = np.stack([ox, oy], -1)
    return np.round((np.clip(q, -1, 1) + 1) * 0.5 * 65535).astype(np.uint16)


def sigma_encode(sigma, lo, hi):
    """σ → uint8 code, uniform in ln σ over [lo, hi]."""
    t = (np.log(np.clip(sigma, lo, hi)) - np.log(lo)) / (np.log(hi) - np.log(lo))
    return np.round(t * 255).astype(np.uint8)


def _pack(mask):
    return np.packbits(mask, axis=-1, bitorder="little")


def encode(mu, sigma, w, sigma_lo: float, sigma_hi: float) -> dict:
    """Compact arrays of fitted Gaussians mu (X, 92, K, 3), sigma (X, 92, K), w (X, 92, K, 3)."""
    _, _, nb, cnt = view_set()
    weighted = np.any(w != 0, axis=(2, 3))                       # (X, 92)
    # a per-vertex float32 scale keeps the half floats in [−1, 1], where their relative
    # precision is 2^-11 (a BRDF's grazing views can exceed the half range, 65504)
    scale = np.abs(w).max(axis=(1, 2, 3))
    scale = np.where(scale > 0, scale, 1.0)
    stored = weighted.copy()
    for v in range(N_VIEWS):
        stored[:, nb[v, :cnt[v]]] |= weighted[:, v:v + 1]
    return {
        "stored_mask": _pack(stored), "weight_mask": _pack(weighted),
        "dirs": oct_encode(mu[stored]), "sigma_code": sigma_encode(sigma[stored], sigma_lo,
                                                                    sigma_hi),
        "weight_scale": scale.astype(np.float32),
        "weights": np.clip(w[weighted] / np.repeat(scale, weighted.sum(1))[:, None, None],
                           -HALF_MAX, HALF_MAX).astype(np.float16),
        "sigma_range": np.array([sigma_lo, sigma_hi], np.float64),
    }


def nbytes(arrays: dict) -> int:
    """Bytes of the compact representation (the arrays' payloads)."""
    return int(sum(np.asarray(a).nbytes for a in arrays.values()))


def paper_bytes(vertices: int, gaussians: int) -> int:
    """Green06 §6.1: 92 × 7 float32 per Gaussian per vertex."""
    return int(vertices) * N_VIEWS * 7 * 4 * int(gaussians)


__all__ = ["oct_encode", "oct_decode", "sigma_encode", "sigma_decode", "encode", "decode",
           "nbytes", "paper_bytes", "MASK_BYTES"]

