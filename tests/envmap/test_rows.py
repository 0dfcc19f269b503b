"""The row-factorised gather of the sharp Γ_L levels (pyramid.rows) against the 2-D sum over the
same masses (`pyramid._gather_jit.sg_gather`, kernel cut further out), seams and corners
included."""
import math

import numpy as np
import pytest

from sgpipe.core.maps import cubemap_texel_dirs
from sgpipe.core.sg import sg_integral
from sgpipe.envmap._cube_jit import FACE_UVA
from sgpipe.envmap.pyramid import BORDER
from sgpipe.envmap.pyramid._gather_jit import sg_gather
from sgpipe.envmap.pyramid._masses_jit import row_extents
from sgpipe.envmap.pyramid.build import EXTRA
from sgpipe.envmap.pyramid.chain import chain_source
from sgpipe.envmap.pyramid.direct import map_grid
from sgpipe.envmap.pyramid.kernels import difference_kernel, sg_kernel
from sgpipe.envmap.pyramid.layers import point_masses
from sgpipe.envmap.pyramid.rows import row_gather

from .envmap_helpers import boxes_cube, sky

N = 256                     # λ_0 = (N/4)² = 4096: sharp enough for the rows
N_CHAIN = 320               # a ratio-2 chain step λ_d = 6400: rows at a 6σ tail
EXT = BORDER + EXTRA


def _masses(cube, contrast):
    """Point masses at the texel centres, single texels at a corner, on an edge and inside a
    face at `contrast` × the median."""
    n = cube.shape[1]
    cube = cube.copy()
    for f, i, j in ((4, 0, 0), (0, n // 2, n - 1), (2, 37, 101)):
        cube[f, i, j] = contrast * np.median(cube)
    src = point_masses(cube)
    return src, row_extents(src)


@pytest.fixture(scope="module")
def dim_masses():
    """What the direct levels sum by rows: the dim layer, contrast ≤ 16 (the pyramid's bright
    threshold)."""
    return _masses(sky(cubemap_texel_dirs(N)), 16.0)


@pytest.fixture(scope="module")
def bright_masses():
    """What a chained level holds when the bright layer stays in the levels: sharp-edged boxes
    (contrast ~470) and single texels at 10³."""
    return _masses(boxes_cube(N_CHAIN), 1e3)


def _both(src, ex, h_src, c0, kern, ref_kern, n_out):
    """(rows used, the 2-D sum with `ref_kern` (the same kernel cut further out: ~exact), the
    rows' result with `kern`) at every bordered output."""
    ref = np.zeros((6, n_out + 2 * EXT, n_out + 2 * EXT, 6))
    sg_gather(src, ex, FACE_UVA, n_out, EXT, float(kern[0]),
                  1.0 - ref_kern[1] / ref_kern[0], 4, ref, ref_kern, h_src, c0)
    rows = np.zeros_like(ref)
    used = row_gather(src, (h_src, c0), kern, n_out, EXT, rows, 0.0)
    return used, ref, rows


def _errors(ref, rows):
    v_err = np.abs(rows[..., :3] / ref[..., :3] - 1.0).max()
    # the slope only steers the λ interpolation: relative to the derivative's own scale
    d_scale = np.abs(ref[..., 3:]).max(axis=(1, 2), keepdims=True)
    d_err = (np.abs(rows[..., 3:] - ref[..., 3:]) / d_scale).max()
    return v_err, d_err


@pytest.mark.parametrize("n_out", [N, 215])
def test_rows_match_the_2d_sum_for_the_sg(dim_masses, n_out):
    """Levels 0 and 1 (stored at another resolution) from the map, kernel cut at 4.5σ: every
    bordered output, across seams and at corners, within 1e-4 of the sum cut at 8σ (the 2-D
    gather adds the other faces' masses in both)."""
    src, ex = dim_masses
    lam = (N / 4.0) ** 2 / (1.0 if n_out == N else math.sqrt(2.0))
    used, ref, rows = _both(src, ex, *map_grid(N), sg_kernel(lam, 4.5), sg_kernel(lam, 8.0),
                            n_out)
    assert used
    v_err, d_err = _errors(ref, rows)
    assert v_err < 1e-4 and d_err < 1e-3, (v_err, d_err)


def test_rows_match_the_2d_sum_for_a_chain_step(bright_masses):
    """A chained level from every other sample of the level two above (the partition-of-unity
    quadrature masses of `chain_source`) with the fitted difference kernel cut at 6σ, bright
    content included: within 5e-4 of the 2-D sum of the same masses and kernel cut at 8σ (the
    B-spline of the row sums in the tails of the brightest texels)."""
    src0, ex0 = bright_masses
    n = N_CHAIN
    lam_a = (n / 4.0) ** 2
    lam_b = lam_a / 2.0
    acc = np.zeros((6, n + 2 * EXT, n + 2 * EXT, 6))
    kern0 = sg_kernel(lam_a, 8.0)
    sg_gather(src0, ex0, FACE_UVA, n, EXT, lam_a, 1.0 - kern0[1] / kern0[0], 4, acc, kern0,
                  *map_grid(n))
    src, ex, h_src, c0 = chain_source(acc, n, EXT, float(sg_integral(lam_a, 1.0)), 2)
    kern, _, _ = difference_kernel(lam_a, lam_b, 6.0)
    ref_kern, _, _ = difference_kernel(lam_a, lam_b, 8.0)
    n_out = int(math.ceil(4.0 * math.sqrt(lam_b)))
    used, ref, rows = _both(src, ex, h_src, c0, kern, ref_kern, n_out)
    assert used
    v_err, d_err = _errors(ref, rows)
    assert v_err < 5e-4 and d_err < 3e-3, (v_err, d_err)


def test_rows_refuse_a_broad_kernel(dim_masses):
    """Too broad for the rows (lines in reach far beyond the faces), or below the configured
    λ_d: nothing added, the caller gathers in 2-D."""
    src, ex = dim_masses
    kern = sg_kernel(60.0, 4.5)
    rows = np.zeros((6, 16 + 2 * EXT, 16 + 2 * EXT, 6))
    assert not row_gather(src, map_grid(N), kern, 16, EXT, rows, 0.0)
    assert not rows.any()
    assert not row_gather(src, map_grid(N), sg_kernel(4096.0, 4.5), N, EXT, rows, 1e4)


@pytest.mark.parametrize("which, k, tol", [("sky_sun", 2.0, 5e-4), ("boxes", 2.0, 3e-3),
                                           ("sky_sun", 0.0, 1e-3), ("boxes", 0.0, 3e-3)])
def test_row_summed_pyramid_matches_brute_force(which, k, tol):
    """A 256² pyramid whose sharp levels are summed by rows (the direct levels, the chain steps
    down to λ_d 500; the boxes' bright layer too, contrast ~470 < 10³) against brute-force
    quadrature at λ on and between those levels, on the cube seams, corners and poles and next
    to the brightest texels, at 2 texels per σ and at the automatic 1.5 (both maps' levels have
    bounded contrast)."""
    from sgpipe.envmap.pyramid import PyramidSettings, build_pyramid

    from .envmap_helpers import brute_gamma, probe_directions, sky_sun_cube
    cube = sky_sun_cube(N) if which == "sky_sun" else boxes_cube(N)
    pyr = build_pyramid(cube, PyramidSettings(texels_per_sigma=k))
    assert pyr.info["texels_per_sigma"] == (k or 1.5)
    assert pyr.info["row_levels"] >= 4
    d = cubemap_texel_dirs(N).reshape(-1, 3)
    lum = cube.sum(-1).reshape(-1)
    rng = np.random.default_rng(5)
    hot = d[np.argsort(lum)[-30:]] + rng.normal(size=(30, 3)) * 0.01
    q = np.vstack([probe_directions(20, seed=11)[::3], hot])
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for lam in (4096.0, 2300.0, 1000.0):
        err = np.abs(pyr.lookup(q, lam) / brute_gamma(cube, q, lam) - 1.0).max()
        assert err < tol, f"λ {lam}: {err:.2e}"


def test_fast_exp_accuracy():
    """The branch-free float32 exponentials of the gathers against libm."""
    from numba import njit
    from sgpipe.envmap.pyramid._exp_jit import exp32_scaled, fast_exp32

    @njit
    def both(x):
        a = np.empty_like(x)
        b = np.empty_like(x)
        for i in range(x.size):
            a[i] = fast_exp32(x[i])
            b[i] = exp32_scaled(x[i] * np.float32(1.0 / 32.0))
        return a, b

    x = -np.linspace(0.0, 32.0, 100001).astype(np.float32)
    a, b = both(x)
    ref = np.exp(x.astype(np.float64))
    assert np.abs(a / ref - 1).max() < 1e-5
    near = x >= -12.0
    assert np.abs(b[near] / ref[near] - 1).max() < 5e-6
    assert np.abs(b / ref - 1).max() < 2.5e-3


@pytest.mark.parametrize("kern", [sg_kernel(16384.0, 4.5), sg_kernel(500.0, 4.5),
                                  difference_kernel(16384.0, 8192.0, 4.5)[0],
                                  difference_kernel(1448.2, 724.1, 4.5)[0],
                                  difference_kernel(1024.0, 512.0, 6.0)[0]],
                         ids=["sg16384", "sg500", "chain16384", "chain1448", "chain1024-t6"])
def test_exponent_poly(kern):
    """Pass 2's line weight exponent as one polynomial in x = sin²h (`exponent_poly`) against
    P(λ_d(1 − cos h)) computed exactly, over every line in reach."""
    from sgpipe.envmap.pyramid._rows_pass2_jit import sin_hmax
    from sgpipe.envmap.pyramid.rows import exponent_poly

    e = exponent_poly(kern)
    x = np.linspace(0.0, sin_hmax(float(kern[0]), float(kern[1])) ** 2, 20001)
    z = kern[0] * x / (1.0 + np.sqrt(1.0 - x))
    exact = z * (kern[2] + z * (kern[3] + z * (kern[4] + z * kern[5])))
    fit = 32.0 * x * (e[0] + x * (e[1] + x * (e[2] + x * e[3])))
    assert np.abs(fit - exact).max() < 1e-7
