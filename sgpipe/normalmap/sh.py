"""Han07 §5, the spherical-harmonic method: NDF coefficients γ_lm per texel, MIP-mapped
linearly (γ_lm(q₀) = Y_lm(n(q₀)), then 2×2 means), and the BRDF's zonal coefficients
ρ̂_l = Λ_l f_l = 2π ∫ f(u) P_l(u) du (eq 11) for Lambert, Blinn–Phong, Torrance–Sparrow /
Beckmann and a tabulated (measured) f(θ_h); eq 12 evaluates the effective BRDF.

SH basis and index order: sgpipe.core.sh (real, orthonormal, k = l(l + 1) + m, pole +z =
the tangent-space normal)."""

from __future__ import annotations

import math

import numpy as np

from sgpipe.brdf.ndf import beckmann_ndf  # noqa: F401  (re-exported: the SH method's D)
from sgpipe.core.sh import (sh_eval, sh_expand_bands, sh_irradiance_coeffs, zonal_coeffs,
                            zonal_theta_rule)
from sgpipe.normalmap.pyramid import level_count


def lambert_coeffs(lmax: int = 2) -> np.ndarray:
    """Clamped cosine f(u) = max(u, 0): ρ̂ = π, 2π/3, π/4, 0, −π/24 … (Ramamoorthi–Hanrahan)."""
    return sh_irradiance_coeffs(lmax)


def blinn_phong_coeffs(s: float, lmax: int) -> np.ndarray:
    """Normalised Blinn–Phong (s + 1)/(2π) max(u, 0)^s (≈ e^{−l²/(2s)}, §5.1)."""
    return zonal_coeffs(lambda u: (s + 1.0) / (2.0 * math.pi) * np.maximum(u, 0.0) ** s, lmax)


def torrance_sparrow_coeffs(sigma: float, lmax: int) -> np.ndarray:
    """Eq 18's lobe e^{−β²/(4σ²)}/(4πσ²) (≈ e^{−(σl)²} for small σ)."""
    return zonal_coeffs(lambda u: np.exp(-np.arccos(np.clip(u, -1, 1)) ** 2 / (4 * sigma ** 2))
                        / (4.0 * math.pi * sigma ** 2), lmax)


def beckmann_coeffs(alpha: float, lmax: int) -> np.ndarray:
    """Beckmann microfacet D as f(ω_h · n) (Torrance–Sparrow's distribution; σ ≈ α/2)."""
    return zonal_coeffs(lambda u: beckmann_ndf(u, alpha), lmax)


def tabulated_coeffs(theta_h: np.ndarray, values: np.ndarray, lmax: int) -> np.ndarray:
    """A measured D(θ_h) table (piecewise linear in θ_h, as sgpipe.brdf.ndf.TabulatedNDF; zero
    below the horizon), scaled so that ∫ D cos θ_h dω = 1 like the analytic microfacet D's."""
    theta_h = np.asarray(theta_h, float)
    values = np.maximum(np.asarray(values, float), 0.0)

    def f(u):
        th = np.arccos(np.clip(u, -1.0, 1.0))
        return np.where(u > 0, np.interp(th, theta_h, values), 0.0)

    th, w = zonal_theta_rule()
    mass = 2.0 * math.pi * float(np.sum(w * f(np.cos(th)) * np.maximum(np.cos(th), 0.0)))
    return zonal_coeffs(f, lmax) / mass


def brdf_coeffs(brdf, lmax: int) -> np.ndarray:
    """ρ̂_l of an `sgpipe.brdf` BRDF's specular distribution (its peak-normalised `ndf`, made a
    unit microfacet density): the measured (MERL / tabulated) and analytic models alike."""
    th, _ = zonal_theta_rule()
    th = th[th < math.pi / 2]
    h = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    return tabulated_coeffs(th, np.asarray(brdf.ndf(h), float).reshape(-1), lmax)


# -- NDF side -------------------------------------------------------------------------------

def ndf_sh_pyramid(normals: np.ndarray, lmax: int, levels: int | None = None) -> list:
    """γ_lm per texel per level, (side_l, side_l, (lmax+1)²) float64: Y_lm(n) at level 0, then
    linear 2×2 MIP-mapping (the averages are exact NDF projections, §5.1)."""
    from sgpipe.normalmap._sh_jit import box_down_map, sh_eval_map, sh_norms
    n = np.ascontiguousarray(normals, np.float64)
    level0 = np.empty(n.shape[:2] + ((lmax + 1) ** 2,))
    sh_eval_map(n, int(lmax), sh_norms(lmax), level0)          # = core.sh.sh_eval(n, lmax)
    out = [level0]
    for _ in range(1, level_count(n.shape[0], levels)):
        m = out[-1].shape[0] // 2
        out.append(np.empty((m, m, level0.shape[2])))
        box_down_map(out[-2], out[-1])                          # = pyramid.box_down
    return out


def effective_brdf(gamma_lm: np.ndarray, rho_hat: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Han07 eq 12: ρ_eff(ω) = Σ_lm ρ̂_l γ_lm Y_lm(ω) for coefficients (..., K) at directions
    (..., 3) in the tangent frame (ω = ω_i for Lambert, ω_h for half-angle BRDFs)."""
    k = gamma_lm.shape[-1]
    lmax = int(round(math.sqrt(k))) - 1
    per_k = sh_expand_bands(np.asarray(rho_hat, float)[:lmax + 1])
    return np.sum(sh_eval(omega, lmax) * gamma_lm * per_k, axis=-1)
