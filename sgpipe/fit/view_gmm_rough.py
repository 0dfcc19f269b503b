"""Per-view vMF mixtures of the glTF metal-rough specular slice at a grid of roughness values,
with Schlick's F0 as a linear basis, for materials whose roughness, metalness or colour comes
from a texture (Töral19 §IV eq 3–5 per grid entry; Wang09 §4.1's textured model parameters).

    grid = fit_rough_view_gmm(0.8, 8, n_theta=16, n_lobes=8)   # RoughViewGMM
    grid.roughness          # (R,) the entries, uniform in ln α (α = roughness²)
    grid.alpha[r, j, k]     # (F0 = 0, F0 = 1, F0 = 1) amplitudes of lobe k at view j

The glTF specular term F·D·G2/(4 cos θ_i cos θ_o) with F = F0 + (1 − F0)(1 − v·h)⁵ is linear
in F0, so one fit of the BRDF with F0 = (0, 1, 1) — base colour (0, 1, 1), metallic 1 — holds
every F0: lobe k's amplitude at a pixel of F0 c is a0 + c (a1 − a0), exact in each channel's
integral (the amplitudes are scaled to each channel's slice integral). The lobes' shape
follows the luminance of that basis BRDF, which F0 = 1 dominates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sgpipe.brdf.models import GLTF_MIN_ROUGHNESS
from sgpipe.fit.view_gmm import ViewGMM, fit_view_gmm

#: the basis BRDF's base colour: Schlick F0 = 0 in channel 0, F0 = 1 in channels 1 and 2
F0_BASIS = (0.0, 1.0, 1.0)


def roughness_entries(roughness_max: float, n: int) -> np.ndarray:
    """n glTF roughness values from GLTF_MIN_ROUGHNESS to roughness_max, uniform in ln α: a
    texel's roughness is its texture value times the material's factor, so never above it.
    One entry (the factor itself) when n is 1 or the factor is at the floor."""
    hi = max(float(roughness_max), GLTF_MIN_ROUGHNESS)
    if n <= 1 or hi <= GLTF_MIN_ROUGHNESS * (1.0 + 1e-6):
        return np.array([hi])
    return np.exp(np.linspace(np.log(GLTF_MIN_ROUGHNESS), np.log(hi), n))


@dataclass
class RoughViewGMM:
    """Arrays of docs/ARTIFACTS.md `view_gmm_rough.npz`: one ViewGMM per roughness entry, all
    on the same view grid and lobe count, specular part only."""

    roughness: np.ndarray    # (R,)
    fits: list[ViewGMM]

    @property
    def alpha(self) -> np.ndarray:
        return np.stack([f.alpha for f in self.fits])

    def arrays(self) -> dict:
        per = [f.arrays() for f in self.fits]
        first = per[0]
        out = {"roughness": self.roughness, "view_theta": first["view_theta"],
               "view_phi": first["view_phi"], "coherent": first["coherent"]}
        for name in ("alpha", "kappa", "mu_theta", "mu_phi", "rel_l2"):
            out[name] = np.stack([p[name] for p in per])
        return out


def basis_brdf(roughness: float):
    """The glTF BRDF with F0 = F0_BASIS (metallic 1) and no diffuse part, at `roughness`."""
    from sgpipe.brdf.models import gltf_pbr
    return gltf_pbr({"base_color": list(F0_BASIS), "metallic": 1.0,
                     "roughness": float(roughness)})


def fit_rough_view_gmm(roughness_max: float, n_entries: int, **kw) -> RoughViewGMM:
    """fit_view_gmm (specular, isotropic) of basis_brdf at each of roughness_entries; `kw` the
    fit's view grid and EM settings (include_diffuse and anisotropic_lobes are fixed here)."""
    kw = {**kw, "include_diffuse": False, "anisotropic_lobes": 0}
    rough = roughness_entries(roughness_max, n_entries)
    return RoughViewGMM(rough, [fit_view_gmm(basis_brdf(r), **kw) for r in rough])


def amplitudes_at(alpha: np.ndarray, f0) -> np.ndarray:
    """Lobe amplitudes (…, 3) for Schlick F0 `f0` (RGB) from the basis amplitudes (…, 3): the
    specular slice is linear in F0 (gmm_shade.cl does the same per pixel)."""
    a0, a1 = alpha[..., :1], alpha[..., 1:2]
    return a0 + np.asarray(f0, float) * (a1 - a0)
