"""Quadrature rules: stated polynomial exactness and sharp-lobe accuracy."""
import numpy as np
import pytest
from scipy.special import gamma

from sgpipe.core import (gauss_legendre, hemisphere_quadrature, integrate_sphere, lobe_quadrature,
                         rotation_between, sg_integral, sphere_quadrature)


def monomial_integral(a, b, c):
    """∫_{S²} x^a y^b z^c dω (Folland 2001)."""
    if a % 2 or b % 2 or c % 2:
        return 0.0
    A, B, C = (a + 1) / 2, (b + 1) / 2, (c + 1) / 2
    return 2 * gamma(A) * gamma(B) * gamma(C) / gamma(A + B + C)


def _monomials(deg):
    return [(a, b, n - a - b) for n in range(deg + 1) for a in range(n + 1) for b in range(n + 1 - a)]


@pytest.mark.parametrize("n_theta,n_phi", [(4, 8), (6, 12), (10, 20)])
def test_sphere_rule_exact_to_stated_degree(n_theta, n_phi):
    deg = min(2 * n_theta - 1, n_phi - 1)
    d, w = sphere_quadrature(n_theta, n_phi)
    assert w.sum() == pytest.approx(4 * np.pi, rel=1e-14)
    for a, b, c in _monomials(deg):
        val = np.sum(w * d[:, 0] ** a * d[:, 1] ** b * d[:, 2] ** c)
        assert val == pytest.approx(monomial_integral(a, b, c), abs=1e-13)
    # the bound is tight: z^(2 n_theta) is not integrated exactly
    c = 2 * n_theta
    assert abs(np.sum(w * d[:, 2] ** c) - monomial_integral(0, 0, c)) > 1e-8


def test_rotated_rule_and_hemisphere():
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    d, w = sphere_quadrature(6, 12, axis=axis)
    for a, b, c in _monomials(11):
        val = np.sum(w * d[:, 0] ** a * d[:, 1] ** b * d[:, 2] ** c)
        assert val == pytest.approx(monomial_integral(a, b, c), abs=1e-12)
    d, w = hemisphere_quadrature(8, 16)
    assert w.sum() == pytest.approx(2 * np.pi) and d[:, 2].min() > 0
    assert np.sum(w * d[:, 2]) == pytest.approx(np.pi)            # ∫ cos over hemisphere
    dh, wh = hemisphere_quadrature(8, 16, axis=axis)
    assert np.all(dh @ axis > 0) and np.sum(wh * (dh @ axis) ** 2) == pytest.approx(2 * np.pi / 3)


@pytest.mark.parametrize("lam", [1e-3, 1.0, 1e2, 1e4, 1e6])
def test_lobe_rule_sharp(lam):
    p = np.array([0.0, 1.0, 0.0])
    val = integrate_sphere(lambda d: np.exp(lam * (d @ p - 1)), n=64, axis=p, lam=lam)
    assert val == pytest.approx(sg_integral(lam, 1.0), rel=1e-10)
    # product of lobe with a smooth function: ∫ e^{λ(cosθ−1)} cos²θ, closed form via GL in t
    t, wt = gauss_legendre(400, -1.0, 1.0) if lam < 50 else (None, None)
    d, w = lobe_quadrature(p, lam)
    got = np.sum(w * np.exp(lam * (d @ p - 1)) * (d @ p) ** 2)
    if t is not None:
        ref = 2 * np.pi * np.sum(wt * np.exp(lam * (t - 1)) * t * t)
    else:  # 2π e^{-λ}∫ t² e^{λt} dt, exact antiderivative, negligible e^{-2λ} terms dropped
        ref = 2 * np.pi * (1 / lam - 2 / lam**2 + 2 / lam**3)
    assert got == pytest.approx(ref, rel=1e-10)


def test_integrate_sphere_plain():
    R = rotation_between([0, 0, 1.0], [1.0, 1.0, 0] / np.sqrt(2))
    f = lambda d: (d @ R[:, 0]) ** 4 + 1.0  # noqa: E731
    assert integrate_sphere(f, n=8) == pytest.approx(4 * np.pi / 5 + 4 * np.pi, rel=1e-13)
