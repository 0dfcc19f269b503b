"""The NDF's SG lobes as a function of roughness (Wang09 §4.1: "spatial variation is encoded by
texturing ... the specific BRDF model parameters"; §4.2: lobes sorted by sharpness for texture
interpolation), for materials whose roughness comes from a texture (glTF metallic-roughness).

    grid = fit_roughness_grid(lambda a: GGXNDF(a), n_lobes=3)   # RoughGrid
    lam, mu = grid.lobes_at(0.2)        # the lobes a pixel of α 0.2 renders with

One LM fit about +z (ndf_sg.fit_iso_lm's model) per α of a grid uniform in ln α, each started
from its neighbour's lobes (λ scaled by the α ratio squared), so that lobe k follows one branch
across the grid and interpolating ln λ and μ linearly in ln α between two entries stays a
lobe set of the same shape. `RoughGrid.mid_rel_l2` measures that interpolation at each cell's
geometric mid α against the exact D, beside `mid_direct_rel_l2`, a direct fit there: within
1.2 % relative L2 up to α 0.5, 4.5 % above, where the sharpness floor _LAM_MIN keeps the lobes
from flattening with the NDF.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from sgpipe.artifacts.fit import rough_lobes_at
from sgpipe.fit.ndf_sg import fit_iso_lm, iso_quadrature, iso_residuals, rel_l2

#: Grid entries, and the α range: glTF roughness 0.06–1 (brdf.models.GLTF_MIN_ROUGHNESS), α =
#: roughness²
GRID_ENTRIES = 49
ALPHA_MIN, ALPHA_MAX = 0.06 ** 2, 1.0
GRID_LOBES = 4
#: the broadest lobe's sharpness floor: sg warps an NDF lobe to sharpness λ/(4|o·h|), and a
#: lobe near λ = 0 spreads over the whole sphere, where sg's per-lobe M_o and cosine are far
#: off (a uniform rough metal rendered 9 % apart from the same material fitted freely); the
#: floor costs fit accuracy only above α ≈ 0.5 (GGX flattens to a constant at α = 1)
_LAM_MIN, _LAM_MAX = 0.3, 1e6
_MU_MIN, _MU_MAX = 1e-6, 1e2
_DEAD = 1e-3


@dataclass
class RoughGrid:
    """D_α(h) ≈ Σ_k amplitude[i, k] e^{sharpness[i, k] (h_z − 1)} at alpha[i] (lobes about +z,
    by increasing sharpness)."""

    alpha: np.ndarray          # (R,) uniform in ln α
    sharpness: np.ndarray      # (R, K)
    amplitude: np.ndarray      # (R, K)
    rel_l2: np.ndarray         # (R,) relative L2 error of each entry's fit
    mid_rel_l2: np.ndarray     # (R − 1,) interpolated lobes at the cells' mid α
    mid_direct_rel_l2: np.ndarray  # (R − 1,) a direct fit at the same α

    def lobes_at(self, alpha: float) -> tuple[np.ndarray, np.ndarray]:
        """(λ (K,), μ (K,)) at α: ln λ and μ linear in ln α between grid entries (the kernels'
        shading.h ndf_lobe); α clamped to the grid."""
        return rough_lobes_at(self.alpha, self.sharpness, self.amplitude, alpha)

    def arrays(self) -> dict:
        f = np.float32
        return {"alpha": self.alpha.astype(f), "sharpness": self.sharpness.astype(f),
                "amplitude": self.amplitude.astype(f), "rel_l2": self.rel_l2.astype(f),
                "mid_rel_l2": self.mid_rel_l2.astype(f),
                "mid_direct_rel_l2": self.mid_direct_rel_l2.astype(f)}


def _samples(ndf):
    c, w = iso_quadrature(ndf.width())
    h = np.stack([np.sqrt(np.maximum(0.0, 1 - c * c)), np.zeros_like(c), c], -1)
    return c, w, ndf.eval(h)


def _lm_from(c, w, d, lam, mu) -> tuple[np.ndarray, np.ndarray]:
    """One bounded least-squares run (trust region) of ndf_sg's isotropic model from (λ, μ):
    bounded so that a lobe the NDF no longer needs (D is flat at α = 1) keeps a finite ln μ
    and ln λ to interpolate."""
    res, jac = iso_residuals(c, d, w)
    lo = np.ravel(np.column_stack([np.full(len(lam), np.log(_LAM_MIN)),
                                   np.full(len(lam), np.log(_MU_MIN))]))
    hi = np.ravel(np.column_stack([np.full(len(lam), np.log(_LAM_MAX)),
                                   np.full(len(lam), np.log(_MU_MAX))]))
    p0 = np.clip(np.ravel(np.column_stack([np.log(np.maximum(lam, 1e-300)),
                                           np.log(np.maximum(mu, 1e-300))])), lo, hi)
    p = least_squares(res, p0, jac=jac, method="trf", bounds=(lo, hi),
                      max_nfev=400 * (len(lam) + 1)).x
    return np.exp(p[0::2]), np.exp(p[1::2])     # lobe k stays lobe k (not re-sorted)


def _err(c, w, d, lam, mu) -> float:
    return rel_l2(d, np.exp(lam[None, :] * (c[:, None] - 1.0)) @ mu, w)


def fit_roughness_grid(make_ndf, *, n_lobes: int = GRID_LOBES, entries: int = GRID_ENTRIES,
                       alpha_min: float = ALPHA_MIN, alpha_max: float = ALPHA_MAX) -> RoughGrid:
    """Lobes of the isotropic NDFs make_ndf(α) on a grid uniform in ln α, fitted from the
    smoothest entry up (its lobes all carry weight: a rougher NDF is flatter, and at α = 1 GGX
    is constant), each from its neighbour."""
    alpha = np.exp(np.linspace(np.log(alpha_min), np.log(alpha_max), entries))
    lam = np.zeros((entries, n_lobes))
    mu = np.zeros((entries, n_lobes))
    err = np.zeros(entries)
    prev = None
    for i in range(entries):
        ndf = make_ndf(alpha[i])
        c, w, d = _samples(ndf)
        if prev is None:
            lam0 = ndf.sg_analytic()[0] if ndf.sg_analytic() else 2.0 / ndf.width() ** 2
            lam[i], mu[i] = _lm_from(c, w, d, *fit_iso_lm(c, d, w, n_lobes, lam0))
        else:
            start = prev[0] * (alpha[i - 1] / alpha[i]) ** 2
            lam[i], mu[i] = _lm_from(c, w, d, start, prev[1])
            # a lobe the NDF no longer needs (μ → 0: GGX flattens to a constant at α = 1)
            # keeps its neighbour's sharpness, so that between the two entries it fades out
            # instead of sweeping its sharpness across the range
            dead = mu[i] < _DEAD * mu[i].sum()
            lam[i, dead] = start[dead]
        err[i] = _err(c, w, d, lam[i], mu[i])
        prev = (lam[i], mu[i])
    grid = RoughGrid(alpha, lam, mu, err, np.zeros(entries - 1), np.zeros(entries - 1))
    for i in range(entries - 1):
        a = float(np.sqrt(alpha[i] * alpha[i + 1]))
        c, w, d = _samples(make_ndf(a))
        grid.mid_rel_l2[i] = _err(c, w, d, *grid.lobes_at(a))
        grid.mid_direct_rel_l2[i] = _err(c, w, d, *_lm_from(c, w, d, *grid.lobes_at(a)))
    return grid
