"""Fig 5's error measures (sgpipe.experiments.green06_lobes) against analytic values: SH of a
spherical Gaussian (its Legendre coefficients), the Haar transform (orthonormal; a dyadic block
needs four coefficients; the truncation error is the dropped coefficients' energy) and the
Gaussian fit of a lobe that is one Gaussian."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import eval_legendre

from sgpipe.experiments.green06_lobes import (gaussian_fit, haar2d, haar_approx, ihaar2d,
                                              relative_l2, sh_approx, sh_order_for)
from sgpipe.transport.sampling import light_cube

AXIS = np.array([0.3, 0.8, -0.52]) / np.linalg.norm([0.3, 0.8, -0.52])


def sg(dirs, lam):
    return np.exp(lam * (dirs @ AXIS - 1.0))


@pytest.mark.parametrize("lam,lmax", [(2.0, 2), (6.25, 2), (6.25, 4)])
def test_sh_error_of_a_spherical_gaussian_is_the_legendre_tail(lam, lmax):
    """Best l ≤ L approximation of a zonal G: error² = ‖G‖² − Σ_{l≤L} c_l², with
    c_l = 2π ∫ G(t) Y_l0(t) dt and ‖G‖² = π (1 − e^{−4λ}) / λ."""
    cube = light_cube(32)
    T = sg(cube.dirs, lam)
    err = relative_l2(sh_approx(T, cube.dirs, cube.omega, lmax), T, cube.omega)
    norm2 = np.pi * (1 - np.exp(-4 * lam)) / lam
    kept = sum((2 * np.pi * quad(lambda t: np.exp(lam * (t - 1)) * eval_legendre(l, t), -1, 1,
                                 epsabs=1e-13)[0]) ** 2 * (2 * l + 1) / (4 * np.pi)
               for l in range(lmax + 1))
    exact = np.sqrt(1 - kept / norm2)
    assert err == pytest.approx(exact, abs=2e-3), (err, exact)


def test_sh_budget_is_the_smallest_order_with_enough_coefficients():
    assert [(sh_order_for(n) + 1) ** 2 for n in (7, 9, 10, 14, 21)] == [9, 9, 16, 16, 25]


def test_haar_is_orthonormal_and_a_quadrant_needs_four_coefficients():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(16, 16))
    c = haar2d(a)
    assert np.allclose(ihaar2d(c), a, atol=1e-12)
    assert np.sum(c ** 2) == pytest.approx(np.sum(a ** 2), rel=1e-12)      # Parseval
    q = np.zeros((16, 16))
    q[:8, 8:] = 1.0
    assert np.count_nonzero(np.abs(haar2d(q)) > 1e-12) == 4


def test_haar_truncation_error_is_the_dropped_energy():
    """On the light cube: T √Ω's Haar coefficients are orthonormal coordinates of the error
    metric, so keeping k of them leaves exactly the others' energy; a quadrant of one face
    (in those coordinates) is exact with 7."""
    res = 16
    cube = light_cube(res)
    sq = np.sqrt(cube.omega)
    T = sg(cube.dirs, 4.0)
    c = np.sort(np.abs(np.stack([haar2d(f) for f in (T * sq).reshape(6, res, res)])).ravel())
    for k in (1, 7, 40):
        err = relative_l2(haar_approx(T, cube.omega, res, k), T, cube.omega)
        assert err == pytest.approx(np.sqrt(np.sum(c[:-k] ** 2) / np.sum(c ** 2)), rel=1e-9)
    block = np.zeros((6, res, res))
    block[2, :8, :8] = 1.0
    Tb = block.ravel() / sq
    assert relative_l2(haar_approx(Tb, cube.omega, res, 7), Tb, cube.omega) < 1e-12


def test_one_gaussian_fits_a_gaussian_exactly():
    cube = light_cube(16)
    T = 2.5 * sg(cube.dirs, 1 / 0.3 ** 2)
    p, approx = gaussian_fit(T, cube.dirs, cube.omega, 1, starts=2)
    assert relative_l2(approx, T, cube.omega) < 1e-6
    assert np.exp(p[0, 2]) == pytest.approx(0.3, rel=1e-6)


def test_exhaustive_single_gaussian_search_finds_the_global_optimum():
    """single_gaussian_search recovers a Gaussian exactly, and on a function one Gaussian
    cannot hold (two separated lobes) it ends at the larger lobe, the best single Gaussian:
    gaussian_fit's one Gaussian is no better (it is the check that fit is not weak)."""
    from sgpipe.experiments.green06_lobes import gaussian_fits, single_gaussian_search
    cube = light_cube(16)
    T = 2.5 * sg(cube.dirs, 1 / 0.3 ** 2)
    p, approx = single_gaussian_search(T, cube.dirs, cube.omega, axes_res=8, sigmas=16)
    assert relative_l2(approx, T, cube.omega) < 1e-6
    a = np.array([0.0, 0.8, 0.6])
    a /= np.linalg.norm(a)
    two = T + 1.5 * np.exp((cube.dirs @ a - 1.0) / 0.2 ** 2)
    _, g = single_gaussian_search(two, cube.dirs, cube.omega, axes_res=8, sigmas=16)
    fits = gaussian_fits(two, cube.dirs, cube.omega, 2, starts=2)
    e_search, e_fit = (relative_l2(x, two, cube.omega) for x in (g, fits[0][1]))
    assert e_search == pytest.approx(e_fit, abs=2e-3) and e_search > 0.1
    assert relative_l2(fits[1][1], two, cube.omega) < 1e-4      # two Gaussians hold it
