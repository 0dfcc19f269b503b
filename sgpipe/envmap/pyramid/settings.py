"""Knobs of the Γ_L pyramid build and its levels: λ_ℓ and face resolution per level (Wang09
eq 34–35; docs/ARTIFACTS.md, `envmap/`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class PyramidSettings:
    """Knobs of the pyramid build (the config section mirrors these)."""

    ratio: float = math.sqrt(2.0)        # λ_ℓ / λ_ℓ₊₁
    texels_per_sigma: float = 0.0        # output texel pitch at a face centre = σ / this;
                                         # 0 = from the content (`auto_texels_per_sigma`)
    finest_texels_per_sigma: float = 2.0  # λ_0: σ = this many finest texels (face centre)
    lambda_min: float = 0.25             # levels continue down to the first λ <= this
    min_res: int = 4                     # smallest face resolution of a level
    src_texels_per_sigma: float = 1.5    # dim layer: coarsest source MIP with σ/h >= this
    bright_src_texels_per_sigma: float = 1.7
    bright_factor: float = 16.0          # texels brighter than this × median go to the bright layer
    tail_dim: float = 4.5                # kernel cut at e^{−T²/2} for the dim layer
    tail_bright: float = 0.0             # 0 = from the bright layer's dynamic range (4.5 … 7)
    tile: int = 4
    max_points: int = 256                # a bright layer of at most this many texels is kept as
                                         # exact point masses instead of pyramid levels
    bright_clusters: bool = False        # a larger one as at most max_points clusters of
                                         # texel blocks (layers.clustered_points)
    chain_lambda_min: float = 20.0       # levels with λ >= this (below the direct levels) are
                                         # computed from a sharper level with the exact
                                         # difference kernel (kernels.py) while its fit is
    chain_max_fit_error: float = 5e-4    # within this (the fit loosens as λ falls and as the
                                         # ratio shrinks); the levels after the chain stops
                                         # come from the moment MIP
    chain_min_sampling: float = 0.7      # and the source level samples the step's
                                         # integrand at >= this many texels per its width
    tail_chain: float = 4.5              # difference kernel cut at this many of its σ
    direct_levels: int = 2               # the sharpest levels come straight from the map's
                                         # texels
    bright_rows_max_contrast: float = 1e3  # a bright layer up to this × the median (lamps)
                                         # is summed by rows too at the direct levels; above
                                         # (a sun) by the exact 2-D gather: the rows'
                                         # B-spline of the row sums loses accuracy in the
                                         # tails of a source that bright
    rows_lambda_min: float = 500.0       # kernels with λ_d >= this are summed row by row
                                         # (rows.py: a few row taps per output instead of
                                         # hundreds of texels)


AUTO_TEXELS_PER_SIGMA = (1.5, 2.0)      # (levels of bounded contrast, a sun in the levels)


def auto_texels_per_sigma(s: PyramidSettings, sun_in_levels: bool) -> float:
    """The levels' storage density: `texels_per_sigma` when set, else 2 texels per σ when a
    bright layer of more than `bright_rows_max_contrast` × the median stays in the levels (a
    sun too large for the point set: its tails next to dark sky need the denser B-spline),
    else 1.5 (levels of bounded contrast: the dim layer, lamps, a point-set sun)."""
    if s.texels_per_sigma > 0.0:
        return float(s.texels_per_sigma)
    return AUTO_TEXELS_PER_SIGMA[1] if sun_in_levels else AUTO_TEXELS_PER_SIGMA[0]


def pyramid_levels(n_finest: int, s: PyramidSettings,
                   k: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """λ_ℓ (decreasing, uniformly log-spaced) and face resolution per level.

    λ_0 is the sharpest kernel the finest texels sample at `finest_texels_per_sigma` = k_0 per
    σ (σ = 1/√λ, face-centre pitch 2/N): λ_0 = (N/(2k_0))²; each level is stored at k texels
    per σ (default `auto_texels_per_sigma` without a sun in the levels):
    n_ℓ = clamp(⌈2k√λ_ℓ⌉, min_res, N).
    """
    k = k or auto_texels_per_sigma(s, False)
    lam0 = (n_finest / (2.0 * s.finest_texels_per_sigma)) ** 2
    lams = [lam0]
    while lams[-1] > s.lambda_min:
        lams.append(lams[-1] / s.ratio)
    lams = np.array(lams)
    res = np.clip(np.ceil(2.0 * k * np.sqrt(lams) - 1e-9), s.min_res, n_finest).astype(np.int64)
    return lams, res
