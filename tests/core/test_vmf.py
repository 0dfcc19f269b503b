"""Han07 eq 15–16 / Algorithm 1: vMF density, A(κ), Banerjee's inverse, SG ↔ vMF."""
import numpy as np
import pytest

from sgpipe.core import (kappa_from_rbar, lobe_quadrature, mean_resultant_length, sg_eval,
                         sg_to_vmf, vmf_pdf, vmf_to_sg)

KAPPAS = [1e-9, 1e-3, 0.1, 1.0, 10.0, 1e3, 1e5, 1e7]


@pytest.mark.parametrize("kappa", KAPPAS)
def test_vmf_normalised_and_mean(kappa):
    mu = np.array([0.6, 0.0, 0.8])
    d, w = lobe_quadrature(mu, kappa, n_per_panel=32, n_phi=64)
    pdf = vmf_pdf(d, mu, kappa)
    assert np.all(np.isfinite(pdf))
    # unit vectors carry ~2e-16 rounding in d·μ, amplified by κ in e^{κ(d·μ − 1)}
    tol = 1e-10 + 4e-16 * kappa
    assert np.sum(w * pdf) == pytest.approx(1.0, rel=tol)
    # A(κ) = E[x·μ]
    assert mean_resultant_length(kappa) == pytest.approx(np.sum(w * pdf * (d @ mu)), rel=10 * tol)


def test_vmf_matches_textbook_form():
    x = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.6, -0.8]])
    mu = np.array([0.0, 0.0, 1.0])
    for k in [0.5, 3.0, 20.0]:
        np.testing.assert_allclose(vmf_pdf(x, mu, k), k / (4 * np.pi * np.sinh(k)) * np.exp(k * x @ mu),
                                   rtol=1e-13)
    assert vmf_pdf(mu, mu, 0.0) == pytest.approx(1 / (4 * np.pi))


def test_mean_resultant_length_branches():
    k = np.array([1e-6, 0.01, 0.19999999, 0.2, 0.20000001, 0.5, 30.0, 1e6])
    # extended-precision reference (80-bit long double keeps the 1/κ cancellation harmless)
    ref = np.array([float(1 / np.tanh(np.longdouble(v)) - 1 / np.longdouble(v))
                    if v > 1e-3 else v / 3 - v**3 / 45 + 2 * v**5 / 945 for v in k])
    np.testing.assert_allclose(mean_resultant_length(k), ref, rtol=2e-14)


def test_banerjee_error_bound():
    # Han07 Alg. 1 line 12: κ ≈ (3r̄ − r̄³)/(1 − r̄²); measured max rel. error 4.94 % at κ ≈ 4.9,
    # → 0 for κ → 0 and as 1/(2κ) for κ → ∞.
    k = np.logspace(-3, 6, 9001)
    rel = kappa_from_rbar(mean_resultant_length(k)) / k - 1.0
    assert np.max(np.abs(rel)) < 0.05
    assert 4.0 < k[np.argmax(np.abs(rel))] < 6.0
    big = k > 1e3
    np.testing.assert_allclose(rel[big], 1.0 / (2.0 * k[big]), rtol=0.05)
    assert np.max(np.abs(rel[k < 0.01])) < 1e-4
    assert kappa_from_rbar(1.0) == np.inf and kappa_from_rbar(0.0) == 0.0


def test_sg_vmf_roundtrip():
    lam = np.array([1e-6, 0.3, 5.0, 1e4])
    mu = np.array([2.0, 0.5, 1.0, 3.0])
    kappa, weight = sg_to_vmf(lam, mu)
    p = np.array([0.0, 1.0, 0.0])
    x = np.array([[0.0, 0.8, 0.6]])
    np.testing.assert_allclose(weight * vmf_pdf(x, p, kappa), sg_eval(x, p, lam, mu), rtol=1e-12)
    l2, m2 = vmf_to_sg(kappa, weight)
    np.testing.assert_allclose(l2, lam)
    np.testing.assert_allclose(m2, mu, rtol=1e-14)
    _, wrgb = sg_to_vmf(lam, np.ones((4, 3)))
    assert wrgb.shape == (4, 3)
