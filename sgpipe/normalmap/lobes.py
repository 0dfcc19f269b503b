"""Radially symmetric lobes of Han07 §6–7: vMF ↔ mean resultant length (eq 16, Algorithm 1
line 12 / Algorithm 2 line 9), vMF zonal SH coefficients (exact and eq 19), and the closed-form
convolutions of a vMF with a Blinn–Phong lobe (eq 20) and a Torrance–Sparrow lobe (eq 21)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def kappa_of_rbar(r: float) -> float:
    """Banerjee's κ = (3r − r³)/(1 − r²) for one length r (Algorithm 2 line 9); r ≥ 1 → 1e30."""
    if r >= 1.0:
        return 1e30
    r = max(r, 0.0)
    return (3.0 * r - r * r * r) / (1.0 - r * r)


@njit(cache=True)
def rbar_of_kappa(kappa: float) -> float:
    """Inverse of `kappa_of_rbar` on [0, 1) (monotone): the length to store so that a lookup's
    Banerjee κ gives back `kappa` (bisection to 1e-15)."""
    if kappa <= 0.0:
        return 0.0
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if kappa_of_rbar(mid) < kappa:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def vmf_zonal_exact(kappa: float, lmax: int) -> np.ndarray:
    """Λ_l γ_l of a normalised vMF (eq 15) for l = 0..lmax: E[P_l(μ·x)] = i_l(κ)/i_0(κ) with the
    modified spherical Bessel functions (exponentially scaled, stable for large κ)."""
    from scipy.special import ive
    l = np.arange(lmax + 1)
    # i_l(κ) = √(π/2κ) I_{l+½}(κ); the common factor and the e^κ scaling cancel in the ratio
    return ive(l + 0.5, float(kappa)) / ive(0.5, float(kappa))


def vmf_zonal_eq19(kappa: float, lmax: int) -> np.ndarray:
    """Han07 eq 19: Λ_l γ_l ≈ e^{−l²/(2κ)} (large-κ Gaussian approximation)."""
    l = np.arange(lmax + 1, dtype=float)
    return np.exp(-l * l / (2.0 * float(kappa)))


def blinn_phong_lobe(cos, s):
    """Normalised Blinn–Phong f(u) = (s + 1)/(2π) max(u, 0)^s (integrates to 1 over S²)."""
    u = np.maximum(np.asarray(cos, float), 0.0)
    return (s + 1.0) / (2.0 * math.pi) * u ** s


def convolved_exponent(s, kappa):
    """Han07 eq 20: a Blinn–Phong lobe of exponent s convolved with a vMF of concentration κ is
    approximately Blinn–Phong with s′ = κ s / (κ + s) about μ."""
    s = np.asarray(s, float)
    kappa = np.asarray(kappa, float)
    return kappa * s / (kappa + s)


def torrance_sparrow_lobe(cos, sigma):
    """Han07 eq 18's lobe e^{−β²/(4σ²)} / (4πσ²), β = angle to the axis (Λ_l f_l = e^{−(σl)²})."""
    beta = np.arccos(np.clip(np.asarray(cos, float), -1.0, 1.0))
    return np.exp(-beta * beta / (4.0 * sigma * sigma)) / (4.0 * math.pi * sigma * sigma)


def convolved_sigma(sigma, kappa):
    """Han07 eq 21: σ′ = √(σ² + 1/(2κ)); with Beckmann α = 2σ this is α′ = √(α² + 2/κ)."""
    return np.sqrt(np.asarray(sigma, float) ** 2 + 0.5 / np.asarray(kappa, float))
