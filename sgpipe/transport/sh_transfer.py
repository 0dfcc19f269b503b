"""Green06 §6.1: the diffuse (view-independent) part as shadowed PRT — per vertex the SH
transfer vector t_k = ∫ V_x(ω) max(n·ω, 0) Y_k(ω) dω (Sloan et al. 2002), 5th order (bands
l = 0…4, 25 coefficients) in the world frame, integrated over the light-cube texels.

Diffuse exit radiance is then f_d · Σ_k L_k t_k with L_k the lighting's SH coefficients in the
same (world, +Z-pole) basis of `sgpipe.core.sh`.
"""

from __future__ import annotations

import numpy as np

from sgpipe.core.sh import sh_eval, sh_expand_bands, sh_irradiance_coeffs
from sgpipe.transport.sampling import LightCube

SH_LMAX = 4   # 5th order: bands 0..4


def texel_basis(light: LightCube, lmax: int = SH_LMAX) -> np.ndarray:
    """(M, K) SH basis at the light texels times their solid angles."""
    return sh_eval(light.dirs, lmax) * light.omega[:, None]


def transfer_vector(basis_omega: np.ndarray, light: LightCube, normal, visibility) -> np.ndarray:
    """(K,) shadowed transfer t_k = Σ_j Ω_j V_j max(n·ω_j, 0) Y_k(ω_j)."""
    cos = np.maximum(light.dirs @ np.asarray(normal, float), 0.0) * visibility
    return cos @ basis_omega


def clamped_cosine_sh(normal, lmax: int = SH_LMAX) -> np.ndarray:
    """Analytic SH of max(n·ω, 0), the unshadowed transfer: by the Funk–Hecke theorem
    ∫ max(n·ω, 0) Y_lm(ω) dω = Â_l Y_lm(n) with Â_l the Ramamoorthi–Hanrahan clamped-cosine convolution constants (π, 2π/3, π/4, 0, −π/24, …)."""
    a = sh_expand_bands(sh_irradiance_coeffs(lmax))
    return a * sh_eval(np.asarray(normal, float), lmax)


__all__ = ["SH_LMAX", "texel_basis", "transfer_vector", "clamped_cosine_sh"]
