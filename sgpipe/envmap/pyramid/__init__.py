"""Γ_L pyramid (Wang09 eq 34–35): the environment convolved with normalized SG kernels.

Level ℓ stores V_ℓ(p) = Γ_L(p, λ_ℓ)/S(λ_ℓ) with Γ_L(p, λ) = ∫ e^{λ(ω·p−1)} L(ω) dω and
S(λ) = 2π(1 − e^{−2λ})/λ, plus the log-slope m_ℓ(p) = ∂ln Γ_L/∂ln λ used to interpolate in λ
(cubic Hermite of ln Γ_L in ln λ). Both are stored as uniform cubic B-spline coefficients on a
bordered cubemap (docs/ARTIFACTS.md, `envmap/`; `lookup`).

Build (`build.build_pyramid`): the cubemap texels become point masses (E = L·Ω at the texel
centre), split in a "dim" layer of bounded contrast and a sparse "bright" layer, kept as exact
points beside the levels when small (`layers`); the storage density and λ_ℓ follow the content
(`settings`). Each level comes from one of three algorithms:
- the direct levels (the sharpest two) straight from the map's masses (`direct`);
- each level below them with λ ≥ `chain_lambda_min` from the samples of a sharper level with
  the exact zonal difference kernel (`kernels`) and a smooth quadrature across the cube edges
  (`chain`), as the chain plan says (`plan`);
- the broad levels from a moment-preserving MIP of the masses (`broad`).
Sharp kernels are summed row by row (`rows`: every cube-face row is a great circle, so a zonal
kernel factorises into a sum along each row and a sum over the rows in reach), broader ones,
and a sun's bright layer at the direct levels, by the 2-D gather (`_gather_jit.sg_gather`). One
buffer pool serves every level (`pool`).
"""
from sgpipe.envmap.pyramid.build import build_pyramid
from sgpipe.envmap.pyramid.lookup import BORDER, Pyramid
from sgpipe.envmap.pyramid.settings import PyramidSettings, auto_texels_per_sigma, pyramid_levels

__all__ = ["BORDER", "Pyramid", "PyramidSettings", "auto_texels_per_sigma", "build_pyramid",
           "pyramid_levels"]
