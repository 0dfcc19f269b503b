"""The sharpest Γ_L levels (Wang09 eq 34) straight from the map's texels: the SG summed over
each layer's finest masses, by rows (`rows`) where the kernel is sharp enough, else by the 2-D
gather."""
from __future__ import annotations

from sgpipe.envmap._cube_jit import FACE_UVA
from sgpipe.envmap.pyramid._gather_jit import sg_gather
from sgpipe.envmap.pyramid.kernels import sg_kernel
from sgpipe.envmap.pyramid.layers import Layers
from sgpipe.envmap.pyramid.rows import reach_t, row_gather
from sgpipe.envmap.pyramid.settings import PyramidSettings


def map_grid(n: int) -> tuple[float, float]:
    """(h, c0) of a plain cubemap face grid: centres at c0 + i·h."""
    return 2.0 / n, -1.0 + 1.0 / n


def direct_reach(lams, res, n_direct: int, s: PyramidSettings, ext: int) -> float:
    """How far (in |t|) the map's lines must reach for every direct level: they are built once,
    for the broadest, and shared."""
    return max(reach_t(float(lams[i]), 0.5 * s.tail_dim ** 2, int(res[i]), ext)
               for i in range(n_direct))


def direct_level(acc, layers: Layers, lam, n, ext: int, s: PyramidSettings, map_lines: dict,
                 t_direct: float, pool) -> bool:
    """Add Γ, ∂Γ/∂λ of the SG of λ over both layers' finest masses to the accumulator `acc` of
    a level of face resolution n; True where a layer was summed by rows. `map_lines` caches the
    map's lines between the direct levels."""
    by_rows = False
    for mip, tail in ((layers.dim, s.tail_dim), (layers.bright, layers.tail_bright)):
        if mip is None:
            continue
        src, ex = mip.level(0)
        kern = sg_kernel(float(lam), tail)
        cos_cut = max(-2.0, 1.0 - tail * tail / (2.0 * lam))
        grid = map_grid(src.shape[1])
        dim = mip is layers.dim
        # a bright layer of high contrast (a sun) stays with the 2-D gather: the rows'
        # B-spline of the row sums is ~1e-3 off in the tails of a 10⁵ × sun
        if (dim or layers.bright_rows) and row_gather(
                src, grid, kern, n, ext, acc, s.rows_lambda_min, map_lines if dim else None,
                t_direct, pool, "lines" if dim else "bright lines"):
            by_rows = True
        else:
            sg_gather(src, ex, FACE_UVA, int(n), ext, float(lam), cos_cut, s.tile, acc, kern,
                      *grid)
    return by_rows
