"""Build a Γ_L pyramid (Wang09 eq 34–35) from a cubemap: the levels in order, each by one of the
three level algorithms (the package docstring), into memory carved up front."""
from __future__ import annotations

import math
import time

import numba
import numpy as np

from sgpipe.core.sg import sg_integral
from sgpipe.core.maps import bordered_box_level
from sgpipe.envmap.pyramid._spline_jit import finish_level
from sgpipe.envmap.pyramid.broad import broad_level
from sgpipe.envmap.pyramid.chain import ChainSources, chained_level
from sgpipe.envmap.pyramid.direct import direct_level, direct_reach
from sgpipe.envmap.pyramid.layers import split_layers
from sgpipe.envmap.pyramid.lookup import BORDER, Pyramid
from sgpipe.envmap.pyramid.plan import chain_plan, chain_tail, direct_count
from sgpipe.envmap.pyramid.pool import BufferPool, level_images
from sgpipe.envmap.pyramid.settings import (PyramidSettings, auto_texels_per_sigma,
                                            pyramid_levels)

EXTRA = 5           # extra computed border consumed by the B-spline prefilter (0.268^5 ≈ 1e-3)


def build_pyramid(cube: np.ndarray, settings: PyramidSettings | None = None) -> Pyramid:
    """Γ_L pyramid of a (6, N, N, 3) cubemap (OpenGL faces; rows ↔ t, columns ↔ s)."""
    s = settings or PyramidSettings()
    cube = np.ascontiguousarray(cube, dtype=np.float64)
    t0 = time.perf_counter()
    layers = split_layers(cube, s)
    k_store = auto_texels_per_sigma(s, layers.sun_in_levels)
    lams, res = pyramid_levels(cube.shape[1], s, k_store)
    n_direct = direct_count(s, len(lams))
    plan = chain_plan(lams, res, n_direct, s, chain_tail(s, layers))
    ext = BORDER + EXTRA
    t_direct = direct_reach(lams, res, n_direct, s, ext)
    map_lines = {}          # the map's lines for the direct levels (built for the broadest)
    pool = BufferPool()
    sources = ChainSources(plan, pool)
    m0 = int(res[0]) + 2 * ext
    scratch = pool.take("prefilter", (numba.get_num_threads(), 3 * m0 * m0), np.float64)
    images = level_images(res, BORDER)
    row_levels = 0          # levels whose sharp kernel was summed row by row
    for idx, (lam, n) in enumerate(zip(lams, res)):
        acc = pool.take("acc", (6, n + 2 * ext, n + 2 * ext, 6), zero=True)
        if idx < n_direct:      # the sharpest levels: straight from the map's texels
            by_rows = direct_level(acc, layers, lam, n, ext, s, map_lines, t_direct, pool)
        elif idx in plan:       # from a sharper level (exact difference kernel)
            by_rows = chained_level(acc, plan[idx], lam, n, ext, s, sources, pool)
        else:                   # broad levels: from the moment MIP of the map
            pool.drop("lines", "C", "source")
            broad_level(acc, layers, lam, n, ext, s)
            by_rows = False
        row_levels += by_rows
        if idx == n_direct - 1:
            map_lines.clear()           # (the chained levels reuse their pool slot)
            pool.drop("bright lines")   # (only the direct levels sum a bright layer by rows)
        norm = float(sg_integral(lam, 1.0))
        finish_level(acc, float(lam), norm, EXTRA, *images[idx], scratch)
        sources.keep(idx, acc, n, ext, norm)
        later = [j for j in range(idx + 1, len(lams)) if j not in plan]
        if later:           # (chained levels need no MIP level)
            layers.release_finer_than(1.0 / math.sqrt(float(lams[later[0]])), s)
    # mean of what the levels hold (the map minus the point set): their λ → 0 limit
    mean = layers.row_energy.sum(axis=(0, 1)) / (4.0 * np.pi)
    info = {"tau_bright": layers.tau, "bright_texels": layers.n_bright,
            "tail_bright": layers.tail_bright,
            "direct_levels": n_direct, "chained_levels": len(plan),   # levels n_direct …
            "row_levels": row_levels,
            "chain_fit_error": max((st.fit_error for st in plan.values()), default=0.0),
            "tail_dim": s.tail_dim, "points": len(layers.point_dirs), "texels_per_sigma": k_store,
            "build_s": time.perf_counter() - t0}
    raw = bordered_box_level(cube, np.float32, layers.bright_texels if layers.as_points else None)
    return Pyramid(lambdas=lams, face_res=res, values=[im[0] for im in images],
                   slopes=[im[1] for im in images], samples=[im[2] for im in images],
                   mean=mean, ratio=s.ratio, info=info, point_dirs=layers.point_dirs,
                   point_energy=layers.point_energy, raw=raw)
