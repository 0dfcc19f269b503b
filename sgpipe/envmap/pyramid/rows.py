"""Row-factorised zonal gather: a sharp Γ_L level (Wang09 eq 34–35) in two cheap passes instead
of one 2-D sum per output (compiled in `_lines_jit`, `_rows_pass1_jit`, `_rows_pass2_jit`).

Every row of a cube face (t = const, also beyond the face) is a great circle. For a mass c on
the row circle C and an output p at angle h from C's plane, with φ the angle along C between c
and p's foot point on C, spherical Pythagoras gives c·p = cos h · cos φ. For a zonal kernel
K = exp(P(z)), z = λ_d(1 − c·p), P(z) = k1 z + k2 z² + k3 z³ + k4 z⁴ (the SG: λ_d = λ, P = −z;
a chain step's difference kernel: `kernels.difference_kernel`):

    z = z_h + cos h · ẑ,   z_h = λ_d(1 − cos h),  ẑ = λ_d(1 − cos φ),  cos h = 1 − z_h/λ_d
    K = e^{P(z_h)} e^{P(ẑ)} e^{D},   D = z_h ẑ (2k2 − k1/λ_d) + O(k3 z_h ẑ (z_h + ẑ), z_h ẑ²/λ_d²)

(the SG: D = z_h ẑ/λ_d exactly). With κ = 2k2 − k1/λ_d, e^D ≈ 1 + κ z_h ẑ: relative error
(κ z_h ẑ)²/2, 2e-6 where the weight e^{−z_h−ẑ} is 1e-2 and λ_d = 16384; the build sums by rows
only down to λ_d = `PyramidSettings.rows_lambda_min`.

Pass 1 (`row_pass1`) convolves each line along itself: at sample points x_k of the line (the
output grid's pitch) C0 = Σ E e^{P(ẑ)} and C1 = Σ E ẑ e^{P(ẑ)}, stored as cubic B-spline
coefficients. Pass 2 (`row_pass2`) sums over the lines in reach of each output, with
V = C0 + κ z_h C1 at the foot:

    Γ(p) = Σ_lines e^{P(z_h)} V,    ∂Γ/∂λ = g0 Γ + g1 Σ_lines e^{P(z_h)} (z_h V + cos h · C1)

for a derivative kernel K·(g0 + g1 z) (the SG: g0 = 0, g1 = −1/λ; a difference kernel's g2 z²,
g3 z³ are dropped: the slope only steers the λ interpolation). The foot of p = (s0, t0, 1) on
the line t_i lies at s = a·s0, a = (1 + t_i²)/(1 + t0 t_i): off the sample grid, so C is
interpolated there with its B-spline. Along an output row the feet of a block of consecutive
outputs drift by |a − 1| per output against them, so one base index per block and five taps
cover every lane and the loads stay contiguous (vectorised). A sum along a row and one over
the rows in reach take tens of taps per output where the 2-D sum takes hundreds of texels.

Seams: the rows of a face (t = const in its gnomonic plane) are the pencil of planes through its
U axis; a neighbouring face across an edge parallel to U has a family of rows or columns in the
same pencil, so its masses are lines of this face's frame too (at |t| > 1, or inside for a
chained level's extended grid). Each face is summed in two frames, rows (U, V) with its own
masses and the two neighbours across its t-edges, and columns (V, U) with the neighbours across
its s-edges (written transposed): every mass of the sphere within reach, no 2-D fallback at the
seams (`_lines_jit.build_lines`).
"""
from __future__ import annotations

import math

import numpy as np

from sgpipe.envmap._cube_jit import FACE_UVA
from sgpipe.envmap.pyramid._lines_jit import build_lines
from sgpipe.envmap.pyramid._rows_pass1_jit import NARR, row_pass1
from sgpipe.envmap.pyramid._rows_pass2_jit import lines_foot, row_pass2, sin_hmax

T_LIM_MAX = 1.6     # rows only while the lines in reach stay within |t| ≤ this of a face's
                    # plane (broader kernels: the lines fan out, the blocks get short and the
                    # 2-D gather of the small level is as fast)


def row_gather(src, grid, kern, n_out, ext, acc, lam_min, lines_cache=None,
               t_build=0.0, pool=None, slot="lines") -> bool:
    """Add Γ, ∂Γ/∂λ of the zonal kernel `kern` (the gather's layout) over the masses `src` (row
    blocks on the grid (h, c0): centres at c0 + i·h) to the bordered accumulator acc by the
    row-factorised passes (the module docstring): each face's rows and columns as two pencils of
    great circles, with the neighbouring faces' masses on the lines of the same pencils. False
    (nothing added) for λ_d below `lam_min` or beyond T_LIM_MAX. `lines_cache` (a dict) keeps
    the lines of `src` for the next call with the same source (built out to t_build); `pool`
    (a `pool.BufferPool`) lends the buffers of the row sums and of the lines (pool slot `slot`:
    the map's cached lines and the chained levels' share one, used one after the other)."""
    lam_d, zcut = float(kern[0]), float(kern[1])
    if lam_d < lam_min:
        return False
    n_out = int(n_out)
    t_lim = reach_t(lam_d, zcut, n_out, ext)
    if t_lim > T_LIM_MAX:   # the lines would fan out far beyond the faces
        return False
    # the lines of a source already built for a level reaching at least as far are reused
    # (the direct levels share the map's); extra lines are out of reach in pass 2
    cached = lines_cache.get("lines") if lines_cache is not None else None
    if cached is not None and cached[0] is src and cached[1] >= t_lim:
        lines = cached[2]
    else:
        t_b = max(t_lim, t_build) if t_build <= T_LIM_MAX else t_lim
        lines = build_lines(src, FACE_UVA, t_b, 0.1,
                            None if pool is None
                            else lambda k, shape: pool.take((slot, k), shape))
        if lines_cache is not None:
            lines_cache["lines"] = (src, t_b, lines)
    key_off, order, t, m_off, m_ca, m_cb, m_s, m_e, own = lines
    foot = lines_foot(key_off, order, t, lam_d, zcut, n_out, int(ext))
    h_o = 2.0 / n_out
    # samples beyond the bordered outputs at each end of a row: the feet's offset, the B-spline
    # taps and a run-in for the prefilter's mirror boundary (0.268¹⁰ ≈ 2e-6)
    margin = int(math.ceil(foot / h_o)) + 14
    m1 = n_out + 2 * (ext + margin) + 6
    x0 = -1.0 + (0.5 - ext - margin) * h_o
    kappa = 2.0 * kern[3] - kern[2] / lam_d
    k6 = np.ascontiguousarray(kern[:6], dtype=np.float64)
    ecoef = exponent_poly(kern)
    # one frame at a time: its lines' row sums stay in the cache for pass 2 and the buffer is
    # small
    for key in range(12):
        a, b = int(key_off[key]), int(key_off[key + 1])
        if a == b:
            continue
        need = (b - a) * NARR * m1
        buf = pool.take("C", (need,)) if pool is not None else np.empty(need, np.float32)
        C = row_pass1(t[a:b], m_off[a:b + 1], m_ca, m_cb, m_s, m_e, k6, n_out, x0, m1, src,
                      own[a:b], float(grid[1]), float(grid[0]), buf)
        row_pass2(C, key_off, order, t, k6, ecoef, float(kappa), float(kern[6]),
                  float(kern[7]), n_out, int(ext), x0, acc, key, key + 1)
    return True


def exponent_poly(kern) -> np.ndarray:
    """(e1, e2, e3, e4) with P(z_h)/32 ≈ x(e1 + e2 x + e3 x² + e4 x³), x = sin²h, z_h =
    λ_d(1 − cos h), over x in [0, sin²h_max] (pass 2's line weight in one polynomial instead of
    ε(x), then P(z_h): half the dependency chain). Least squares on Chebyshev nodes; within
    1e-8 of the exact exponent for the SG and the pyramid's difference kernels."""
    lam, zcut = float(kern[0]), float(kern[1])
    xm = sin_hmax(lam, zcut) ** 2
    x = 0.5 * xm * (1.0 - np.cos(np.pi * (np.arange(64) + 0.5) / 64))
    eps = x / (1.0 + np.sqrt(1.0 - x))
    z = lam * eps
    p = z * (kern[2] + z * (kern[3] + z * (kern[4] + z * kern[5])))
    y = x / xm                                              # well-conditioned basis
    c, *_ = np.linalg.lstsq(np.stack([y ** n for n in range(1, 5)], axis=1), p / 32.0,
                            rcond=None)
    return np.ascontiguousarray(c / xm ** np.arange(1, 5))


def reach_t(lam_d: float, zcut: float, n_out: int, ext: int) -> float:
    """Largest |t| of a line any bordered output can reach (for `_lines_jit.build_lines`)."""
    h_o = 2.0 / n_out
    sin_max = sin_hmax(lam_d, zcut)
    e = 1.0 + (ext + 0.5) * h_o
    r0 = math.sqrt(1.0 + 2.0 * e * e)
    t = e
    for _ in range(3):
        t = e + sin_max * r0 * math.sqrt(1.0 + t * t)
    return t
