"""The chain plan of a Γ_L pyramid build: which levels come from a sharper level by the exact
zonal difference kernel (`kernels.difference_kernel`) instead of from the map.

Level b ≥ n_direct comes from a sharper level a while λ, a's sampling and the kernel fit allow.
The quadrature of V_a·Δ on a's grid (pitch h at a face centre) is off by ~e^{−2π²(σ_e/h)²},
σ_e² = (1 − λ_b/λ_a)/λ_a the integrand's width. Preferred: a = b − 2 (λ ratio 2) on every other
texel of a (σ_e/h = 0.71 at 2 texels per σ, fewer taps than a = b − 1 on all its texels); at 1.5
texels per σ every other texel would sample the step at < `chain_min_sampling`, so each level
comes from the level above on every texel. A small ratio (1.1) samples the step too coarsely at
either distance (σ_e/h ≈ 0.6) and is not chained.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from sgpipe.envmap.pyramid.kernels import difference_kernel
from sgpipe.envmap.pyramid.layers import Layers
from sgpipe.envmap.pyramid.settings import PyramidSettings


class ChainStep(NamedTuple):
    """Level b from level `src` = b − `step` on every `step`-th of its texels."""

    src: int
    step: int
    kern: np.ndarray                    # the difference kernel (`_gather_jit.sg_gather` layout)
    amp: float                          # its amplitude
    fit_error: float


def direct_count(s: PyramidSettings, n_levels: int) -> int:
    """How many of the sharpest levels come straight from the map's texels (at least one)."""
    return max(1, min(s.direct_levels, n_levels))


def chain_tail(s: PyramidSettings, layers: Layers) -> float:
    """Where a chained level cuts its kernel, in σ of the difference kernel: bright texels kept
    in the levels need the longer tail of their dynamic range."""
    return max(s.tail_chain, layers.tail_bright) if layers.bright is not None else s.tail_chain


def chain_plan(lams: np.ndarray, res: np.ndarray, n_direct: int, s: PyramidSettings,
               tail: float) -> dict[int, ChainStep]:
    """{b: ChainStep} for the levels b ≥ n_direct chained from a sharper level (the module
    docstring), in order, up to the first level that cannot be."""
    plan = {}
    for b in range(n_direct, len(lams)):
        if lams[b] < s.chain_lambda_min * (1 - 1e-9):
            break
        for a, step in ((b - 2, 2), (b - 1, 1)):
            if a < 0 or (a >= n_direct and a not in plan):
                continue
            sigma_e = math.sqrt((1.0 - lams[b] / lams[a]) / lams[a])
            if sigma_e * res[a] / (2.0 * step) < s.chain_min_sampling:
                continue
            kern, amp, err = difference_kernel(float(lams[a]), float(lams[b]), tail)
            if err <= s.chain_max_fit_error:
                plan[b] = ChainStep(a, step, kern, amp, err)
                break
        if b not in plan:
            break
    return plan
