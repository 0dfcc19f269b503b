"""Real SH up to l = 6: orthonormality, convention, projection, Ramamoorthi–Hanrahan irradiance."""
import numpy as np
import pytest
from scipy.special import sph_harm_y

from sgpipe.core import (hemisphere_quadrature, sh_eval, sh_expand_bands, sh_index,
                         sh_irradiance_coeffs, sh_project, sh_reconstruct, sphere_quadrature)

from .conftest import unit

LMAX = 6


def test_orthonormal_by_quadrature():
    d, w = sphere_quadrature(LMAX + 2, 2 * LMAX + 3)     # exact for degree 2·LMAX + 1 products
    Y = sh_eval(d, LMAX)
    np.testing.assert_allclose((Y * w[:, None]).T @ Y, np.eye((LMAX + 1) ** 2), atol=1e-13)


def test_convention_against_scipy(rng):
    d = unit(rng.normal(size=(300, 3)))
    theta = np.arccos(d[:, 2])
    phi = np.arctan2(d[:, 1], d[:, 0])
    Y = sh_eval(d, LMAX)
    for l in range(LMAX + 1):
        for m in range(-l, l + 1):
            c = sph_harm_y(l, abs(m), theta, phi) * (-1) ** abs(m)   # remove Condon–Shortley
            ref = c.real if m == 0 else np.sqrt(2) * (c.real if m > 0 else c.imag)
            np.testing.assert_allclose(Y[:, sh_index(l, m)], ref, atol=1e-12)
    c1 = np.sqrt(3 / (4 * np.pi))
    np.testing.assert_allclose(sh_eval(np.eye(3), 1)[:, 1:], c1 * np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0.0]]),
                               atol=1e-15)   # (Y_1,-1, Y_10, Y_11) = c (y, z, x)


def test_project_reconstruct(rng):
    coeffs = rng.normal(size=((LMAX + 1) ** 2, 3))
    d, w = sphere_quadrature(LMAX + 2, 2 * LMAX + 3)
    f = sh_reconstruct(coeffs, d)
    np.testing.assert_allclose(sh_project(f, d, w, LMAX), coeffs, atol=1e-12)


def test_irradiance_coeffs():
    # Â_l = 2π ∫_0^1 t P_l(t) dt (zonal kernel max(0, cos) with the sqrt(4π/(2l+1)) factor folded in)
    from numpy.polynomial.legendre import Legendre
    from sgpipe.core import gauss_legendre
    t, wt = gauss_legendre(20, 0.0, 1.0)
    num = np.array([2 * np.pi * np.sum(wt * t * Legendre.basis(l)(t)) for l in range(9)])
    np.testing.assert_allclose(sh_irradiance_coeffs(8), num, atol=1e-14)
    np.testing.assert_allclose(sh_irradiance_coeffs(6)[[0, 1, 2, 4, 6]],
                               [np.pi, 2 * np.pi / 3, np.pi / 4, -np.pi / 24, np.pi / 64], rtol=1e-14)
    assert sh_expand_bands(np.arange(3)).tolist() == [0, 1, 1, 1, 2, 2, 2, 2, 2]


def test_irradiance_vs_direct_quadrature(rng):
    # band-limited radiance: the convolution theorem is exact, so SH irradiance == quadrature
    L = rng.normal(size=(LMAX + 1) ** 2)
    normals = unit(rng.normal(size=(20, 3)))
    E_sh = sh_reconstruct(sh_expand_bands(sh_irradiance_coeffs(LMAX)) * L, normals)
    for n, e in zip(normals, E_sh):
        d, w = hemisphere_quadrature(24, 48, axis=n)
        assert np.sum(w * sh_reconstruct(L, d) * (d @ n)) == pytest.approx(e, abs=1e-11)
