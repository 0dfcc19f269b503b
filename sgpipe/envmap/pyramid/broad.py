"""The broad Γ_L levels (Wang09 eq 34): 2-D gathers from each layer's moment-preserving MIP
(energy, energy-weighted centroid and spread per merged texel), at the coarsest MIP level that
still samples the level's kernel finely enough."""
from __future__ import annotations

import math

import numpy as np

from sgpipe.envmap._cube_jit import FACE_UVA
from sgpipe.envmap.pyramid._gather_jit import sg_gather
from sgpipe.envmap.pyramid.direct import map_grid
from sgpipe.envmap.pyramid.layers import Layers
from sgpipe.envmap.pyramid.settings import PyramidSettings

_SPREAD = np.zeros(0)       # `sg_gather`'s kernel for spread masses (the SG of λ, moment-corrected)


def broad_level(acc, layers: Layers, lam, n, ext: int, s: PyramidSettings) -> None:
    """Add Γ, ∂Γ/∂λ of the SG of λ over both layers' MIP masses to the accumulator `acc` of a
    level of face resolution n."""
    sigma = 1.0 / math.sqrt(lam)
    for mip, k_src, tail in ((layers.dim, s.src_texels_per_sigma, s.tail_dim),
                             (layers.bright, s.bright_src_texels_per_sigma, layers.tail_bright)):
        if mip is None:
            continue
        src, ex = mip.source(sigma, k_src)
        cos_cut = max(-2.0, 1.0 - tail * tail / (2.0 * lam))
        # small levels: wider tiles (fewer, longer passes over the broad kernel's source rows)
        tile = s.tile if n > 32 else 2 * s.tile
        sg_gather(src, ex, FACE_UVA, int(n), ext, float(lam), cos_cut, tile, acc, _SPREAD,
                  *map_grid(src.shape[1]))
