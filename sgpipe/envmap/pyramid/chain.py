"""Chained Γ_L levels (Wang09 eq 34–35): level b from the samples of a sharper level a as
V_b = V_a ⊗ Δ with the exact zonal difference kernel Δ (`kernels.difference_kernel`), the
samples taken as quadrature masses smooth across the cube edges (`chain_source`)."""
from __future__ import annotations

import numpy as np

from sgpipe.envmap._cube_jit import FACE_UVA
from sgpipe.envmap.pyramid._chain_jit import chain_source as _chain_source_jit
from sgpipe.envmap.pyramid._chain_jit import chain_source_shape
from sgpipe.envmap.pyramid._gather_jit import sg_gather
from sgpipe.envmap.pyramid._masses_jit import row_extents
from sgpipe.envmap.pyramid.plan import ChainStep
from sgpipe.envmap.pyramid.pool import BufferPool
from sgpipe.envmap.pyramid.rows import row_gather
from sgpipe.envmap.pyramid.settings import PyramidSettings

CHAIN_PAD = 7       # chain source: texels kept beyond each face edge (a subsampled grid must
                    # still reach past the blend)
CHAIN_BLEND = 5.0   # half-width of the faces' partition-of-unity blend, in texels (a subsampled
                    # source needs it this wide to be as accurate near the edges as a full one)


def chain_source(acc, n: int, ext: int, norm: float, step: int, out=None):
    """A level's V = Γ/S on its grid extended CHAIN_PAD texels beyond each face (from the
    gather's accumulator, border `ext`) as quadrature masses at the texel centres: the sources
    of the next chained level, as (row blocks, row extents, h, c0). The weights are the
    midpoint rule in each face's gnomonic coordinates (J·h², J = (1+s²+t²)^{−3/2}, h = 2/n)
    times the face's share of a smooth partition of unity across the edges, so φ_f·J is smooth
    and vanishes towards the extended grid's rim: no edge or corner error terms (texel solid
    angles as weights leave one at every level, accumulating down the chain). `step` 2 keeps
    every other texel. `out`: a zeroed buffer of `chain_source_shape` (default: allocated)."""
    shape = chain_source_shape(n, CHAIN_PAD, step)
    src = np.zeros(shape, np.float32) if out is None else out
    _chain_source_jit(acc, n, ext, norm, CHAIN_PAD, CHAIN_BLEND, FACE_UVA, step, src)
    h = 2.0 / n
    return src, row_extents(src), step * h, -1.0 + (0.5 - CHAIN_PAD) * h


class ChainSources:
    """The levels the plan chains from, kept as quadrature masses in pool slots until their
    chained level takes them. A source is consumed by level a + 1 or a + 2 before level a + 2
    makes the next one of the same parity, so two slots (by level parity) suffice; with steps
    from b − 1 only, one."""

    def __init__(self, plan: dict[int, ChainStep], pool: BufferPool):
        self.plan = plan
        self.pool = pool
        self.two_slots = any(b - st.src == 2 for b, st in plan.items())
        self.made = {}

    def keep(self, level: int, acc, n: int, ext: int, norm: float) -> None:
        """Make level `level`'s sources for every chain step that starts there."""
        n = int(n)
        for st in self.plan.values():
            if st.src == level:
                key = ("source", level % 2 if self.two_slots else 0, st.step)
                out = self.pool.take(key, chain_source_shape(n, CHAIN_PAD, st.step), zero=True)
                self.made[(level, st.step)] = chain_source(acc, n, ext, norm, st.step, out)

    def pop(self, st: ChainStep):
        return self.made.pop((st.src, st.step))


def chained_level(acc, st: ChainStep, lam, n, ext: int, s: PyramidSettings,
                  sources: ChainSources, pool: BufferPool) -> bool:
    """Add Γ, ∂Γ/∂λ of the chain step `st` to the accumulator `acc` of the level of λ and face
    resolution n, by rows where the difference kernel is sharp enough; True if by rows."""
    src, ex, h_src, c0 = sources.pop(st)
    by_rows = row_gather(src, (h_src, c0), st.kern, n, ext, acc, s.rows_lambda_min, pool=pool)
    if not by_rows:
        pool.drop("lines", "C")     # (broader chain steps are not summed by rows)
        cos_cut = max(-2.0, 1.0 - st.kern[1] / st.kern[0])
        sg_gather(src, ex, FACE_UVA, int(n), ext, float(lam), cos_cut, s.tile, acc,
                  st.kern, h_src, c0)
    acc *= st.amp
    return by_rows
