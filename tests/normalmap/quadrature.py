"""Reference quadratures on the sphere for the normal-map tests."""

from __future__ import annotations

import math

import numpy as np


def polar_rule(n_beta: int = 400, n_phi: int = 256, beta_max: float = math.pi):
    """Directions (N, 3) about +z and weights (N,) integrating over the cap β ≤ beta_max:
    composite Gauss–Legendre in β (dense near the pole) × the periodic trapezoid in φ."""
    edges = np.unique(np.concatenate([[0.0], np.geomspace(1e-3, beta_max, 12)]))
    x, w = np.polynomial.legendre.leggauss(max(8, n_beta // (len(edges) - 1)))
    be, bw = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        be.append(0.5 * (b - a) * x + 0.5 * (a + b))
        bw.append(0.5 * (b - a) * w)
    be, bw = np.concatenate(be), np.concatenate(bw) * np.sin(np.concatenate(be))
    phi = (np.arange(n_phi) + 0.5) * 2 * math.pi / n_phi
    B, P = np.meshgrid(be, phi, indexing="ij")
    d = np.stack([np.sin(B) * np.cos(P), np.sin(B) * np.sin(P), np.cos(B)], -1).reshape(-1, 3)
    wt = (bw[:, None] * np.full(n_phi, 2 * math.pi / n_phi)[None, :]).reshape(-1)
    return d, wt


def frame(mu):
    """Rotation (3, 3) whose columns are t, b, μ (maps +z to μ)."""
    mu = np.asarray(mu, float) / np.linalg.norm(mu)
    h = np.array([1.0, 0, 0]) if abs(mu[0]) < 0.9 else np.array([0, 1.0, 0])
    t = h - (h @ mu) * mu
    t /= np.linalg.norm(t)
    return np.stack([t, np.cross(mu, t), mu], 1)


def vmf_samples_stratified(mu, kappa: float, n: int, m: int | None = None) -> np.ndarray:
    """n·m (default n²) directions from vMF(μ, κ) by the inverse CDF on a midpoint grid."""
    m = n if m is None else m
    U, V = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(m) + 0.5) / m, indexing="ij")
    w = 1.0 + np.log(U + (1.0 - U) * np.exp(-2.0 * kappa)) / kappa   # cos β
    s = np.sqrt(np.maximum(1 - w * w, 0))
    phi = 2 * math.pi * V
    local = np.stack([s * np.cos(phi), s * np.sin(phi), w], -1).reshape(-1, 3)
    return local @ frame(mu).T
