"""von Mises–Fisher lobes on S² (Han07 eq 15–16, Algorithm 1) and their SG equivalents."""
from __future__ import annotations

import numpy as np

_TWO_PI = 2.0 * np.pi


def _norm_const(kappa):
    """κ / (2π (1 − e^{−2κ})) = κ e^{−κ} / (4π sinh κ); limit 1/(4π) as κ → 0."""
    kappa = np.asarray(kappa, float)
    small = kappa < 1e-12
    ks = np.where(small, 1.0, kappa)
    return np.where(small, 1.0 / (4.0 * np.pi) * (1.0 + kappa), ks / (_TWO_PI * -np.expm1(-2.0 * ks)))


def vmf_pdf(x, mu, kappa):
    """Han07 eq 15: κ/(4π sinh κ) e^{κ μ·x}, evaluated as κ/(2π(1−e^{−2κ})) e^{κ(μ·x−1)}."""
    kappa = np.asarray(kappa, float)
    c = np.sum(np.asarray(x, float) * np.asarray(mu, float), axis=-1)
    return _norm_const(kappa) * np.exp(kappa * (c - 1.0))


def mean_resultant_length(kappa):
    """Han07 eq 16: A(κ) = coth κ − 1/κ = ‖E[x]‖ of a vMF (Laurent series below κ = 0.2)."""
    kappa = np.asarray(kappa, float)
    small = kappa < 0.2
    ks = np.where(small, 1.0, kappa)
    coth = -(1.0 + np.exp(-2.0 * ks)) / np.expm1(-2.0 * ks)
    k2 = kappa * kappa
    # Σ 2^{2n} B_{2n} κ^{2n−1}/(2n)!, truncation < 5e-15 relative for κ < 0.2
    series = kappa * (1 / 3 + k2 * (-1 / 45 + k2 * (2 / 945 + k2 * (-1 / 4725 + k2 * (
        2 / 93555 + k2 * (-1382 / 638512875))))))
    return np.where(small, series, coth - 1.0 / ks)


def kappa_from_rbar(rbar):
    """Han07 Alg. 1 line 12 (Banerjee 2005, d = 3): κ ≈ (3r̄ − r̄³)/(1 − r̄²); r̄ ≥ 1 → inf."""
    r = np.asarray(rbar, float)
    with np.errstate(divide="ignore"):
        return np.where(r < 1.0, (3.0 * r - r**3) / np.maximum(1.0 - r * r, 0.0), np.inf)


def sg_to_vmf(lam, mu):
    """SG μ e^{λ(v·p−1)} = weight · vMF(v; p, κ=λ) with weight = ∫G = 2πμ(1−e^{−2λ})/λ."""
    lam = np.asarray(lam, float)
    w = np.asarray(mu, float) / _norm_const(lam) if np.ndim(mu) <= lam.ndim or lam.ndim == 0 \
        else np.asarray(mu, float) / _norm_const(lam)[..., None]
    return lam.copy(), w


def vmf_to_sg(kappa, weight):
    """Inverse of sg_to_vmf: λ = κ, μ = weight · κ/(2π(1 − e^{−2κ}))."""
    kappa = np.asarray(kappa, float)
    c = _norm_const(kappa)
    weight = np.asarray(weight, float)
    mu = weight * c if weight.ndim <= kappa.ndim or kappa.ndim == 0 else weight * c[..., None]
    return kappa.copy(), mu
