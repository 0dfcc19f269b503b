"""Compact storage of the fitted Gaussians (Green06 §6.1 stores 92 × 7 float32 per Gaussian per
vertex): octahedral unit directions in 2 × uint16, σ as an 8-bit log code, RGB weights as half
floats (scaled by one float32 per vertex), and only the views the renderer can reach — views
with a nonzero weight and their neighbours (needed to interpolate towards the horizon); colour
only for the weighted views.
Per vertex two 92-bit masks say which views are stored and which carry colour."""

from __future__ import annotations

import numpy as np

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


def oct_decode(e):
    """Octahedral uint16 (..., 2) → unit directions (..., 3)."""
    q = np.asarray(e, float) / 65535 * 2 - 1
    x, y = q[..., 0], q[..., 1]
    z = 1 - np.abs(x) - np.abs(y)
    t = np.maximum(-z, 0.0)
    x = x - np.where(x >= 0, t, -t)
    y = y - np.where(y >= 0, t, -t)
    v = np.stack([x, y, z], -1)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def sigma_encode(sigma, lo, hi):
    """σ → uint8 code, uniform in ln σ over [lo, hi]."""
    t = (np.log(np.clip(sigma, lo, hi)) - np.log(lo)) / (np.log(hi) - np.log(lo))
    return np.round(t * 255).astype(np.uint8)


def sigma_decode(code, lo, hi):
    return np.exp(np.log(lo) + np.asarray(code, float) / 255 * (np.log(hi) - np.log(lo)))


def _pack(mask):
    return np.packbits(mask, axis=-1, bitorder="little")


def _unpack(bits):
    return np.unpackbits(bits, axis=-1, count=N_VIEWS, bitorder="little").astype(bool)


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


def decode(arrays: dict):
    """Full arrays (mu, sigma, w, stored (X, 92) bool) of `encode`'s output; views not stored
    get μ = 0, σ = 0 and w = 0 (the renderer never reaches them with a nonzero weight)."""
    stored, weighted = _unpack(arrays["stored_mask"]), _unpack(arrays["weight_mask"])
    K = arrays["dirs"].shape[1]
    X = stored.shape[0]
    lo, hi = arrays["sigma_range"]
    mu = np.zeros((X, N_VIEWS, K, 3))
    sigma = np.zeros((X, N_VIEWS, K))
    w = np.zeros((X, N_VIEWS, K, 3))
    mu[stored] = oct_decode(arrays["dirs"])
    sigma[stored] = sigma_decode(arrays["sigma_code"], lo, hi)
    scale = np.repeat(arrays["weight_scale"].astype(np.float64), weighted.sum(1))
    w[weighted] = arrays["weights"].astype(np.float64) * scale[:, None, None]
    return mu, sigma, w, stored


def nbytes(arrays: dict) -> int:
    """Bytes of the compact representation (the arrays' payloads)."""
    return int(sum(np.asarray(a).nbytes for a in arrays.values()))


def paper_bytes(vertices: int, gaussians: int) -> int:
    """Green06 §6.1: 92 × 7 float32 per Gaussian per vertex."""
    return int(vertices) * N_VIEWS * 7 * 4 * int(gaussians)


__all__ = ["oct_encode", "oct_decode", "sigma_encode", "sigma_decode", "encode", "decode",
           "nbytes", "paper_bytes", "MASK_BYTES"]


def read_gaussians(folder, obj: str):
    """(mu (X, 92, K, 3), sigma (X, 92, K) radians, w (X, 92, K, 3), stored (X, 92) bool) of one
    object's transport artifact."""
    from sgpipe.artifacts.transport import read_packed_gaussians
    return decode(read_packed_gaussians(folder, obj))
