"""Green06 §6.1: the diffuse (view-independent) part as shadowed PRT — per vertex the SH
transfer vector t_k = ∫ V_x(ω) max(n·ω, 0) Y_k(ω) dω (Sloan et al. 2002), 5th order (bands
l = 0…4, 25 coefficients) in the world frame, integrated over the light-cube texels.

Diffuse exit radiance is then f_d · Σ_k L_k t_k with L_k the lighting's SH coefficients in the
same (world, +Z-pole) basis of `sgpipe.core.sh`.

Interreflected transfer (Sloan et al. 2002 §5, the bounce integral): the occluded directions
bring the radiance leaving the surfaces they meet, t_k += Σ_{j occluded} Ω_j (n·ω_j) ⟨L_y⟩_k
with ⟨L_y⟩_k that surface's outgoing radiance per unit SH lighting coefficient. Sloan gathers
it from the neighbours' diffuse transfer vectors, pass after pass; here it is estimated by
paths from the hit point (its BRDF's importance samples through up to `bounces` surfaces, each
escaping path adding throughput × Y_k(escape direction)), so glossy neighbours count too and the
work stays per vertex. The transfer becomes RGB (the neighbours' colours).
"""

from __future__ import annotations

import numpy as np

from sgpipe.core.sh import sh_eval, sh_expand_bands, sh_irradiance_coeffs
from sgpipe.transport.sampling import LightCube, PathScene, follow_paths

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


def interreflected_transfer(scene: PathScene, light: LightCube, position, normal, visibility,
                            *, paths: int, bounces: int, offset: float, rng,
                            lmax: int = SH_LMAX) -> np.ndarray:
    """(K, 3) indirect transfer (module docstring): for every light texel above the horizon
    whose ray is occluded, `paths` paths from the surface it meets; to be added to the
    shadowed `transfer_vector`. Zero for `bounces` < 1."""
    k = (lmax + 1) ** 2
    out = np.zeros((k, 3))
    n = np.asarray(normal, np.float64)
    cos = light.dirs @ n
    occ = np.flatnonzero((cos > 0) & ~np.asarray(visibility, bool))
    if bounces < 1 or len(occ) == 0:
        return out
    j = np.repeat(occ, paths)
    dirs = light.dirs[j]
    origin = np.asarray(position, np.float64) + offset * n
    beta = np.repeat((light.omega[j] * cos[j] / paths)[:, None], 3, axis=1)
    _, d, b = follow_paths(scene, np.broadcast_to(origin, dirs.shape), dirs, beta, bounces,
                           offset, rng)
    return sh_eval(d, lmax).T @ b if len(d) else out


__all__ = ["SH_LMAX", "texel_basis", "transfer_vector", "clamped_cosine_sh",
           "interreflected_transfer"]
