"""Han07 §5: NDF SH coefficients vs quadrature, BRDF ρ̂_l vs analytic values, and the
eq 11/12 convolution of a vMF NDF with a BRDF lobe vs direct quadrature."""

import math

import numpy as np
import pytest
from scipy.special import eval_legendre

from sgpipe.brdf import make_brdf
from sgpipe.brdf.tabulated import NDF_THETA
from sgpipe.core.sh import sh_eval
from sgpipe.core.vmf import vmf_pdf
from sgpipe.normalmap import sh
from sgpipe.normalmap.lobes import blinn_phong_lobe, vmf_zonal_eq19, vmf_zonal_exact
from sgpipe.normalmap.pyramid import box_down, texel_normals

from .helpers import tilted_normals
from .quadrature import frame, polar_rule, vmf_samples_stratified


def test_lambert_rho_hat_numeric_equals_analytic():
    got = sh.zonal_coeffs(lambda u: np.maximum(u, 0.0), 4)
    np.testing.assert_allclose(got[:3], [math.pi, 2 * math.pi / 3, math.pi / 4], rtol=1e-10)
    np.testing.assert_allclose(got, sh.lambert_coeffs(4), atol=1e-10)
    assert abs(got[4] + math.pi / 24) < 1e-10


def test_pyramid_is_the_mean_of_the_covered_normals():
    n = tilted_normals(8, seed=2)
    n[0, 0] = [0.0, 0.0, 1.0]                                  # the pole
    n[0, 1] = [0.6, -0.8, 0.0]                                 # the equator
    pyr = sh.ndf_sh_pyramid(n, 3)
    np.testing.assert_allclose(sh.ndf_sh_pyramid(n, 8)[0], sh_eval(n, 8), atol=1e-14)
    np.testing.assert_array_equal(pyr[2], box_down(pyr[1]))
    assert len(pyr) == 4 and pyr[3].shape == (1, 1, 16)
    for lev, (r, c) in [(1, (2, 3)), (2, (1, 0)), (3, (0, 0))]:
        want = sh_eval(texel_normals(n, lev, r, c), 3).mean(axis=0)
        np.testing.assert_allclose(pyr[lev][r, c], want, atol=1e-14)


def test_sh_projection_of_a_vmf_texel_vs_quadrature():
    """A texel whose 64² normals are stratified draws from vMF(μ, 6): its top-level γ_lm
    (means of Y_lm) equals ∫ vMF(n) Y_lm(n) dn by quadrature, and the zonal part matches the
    exact vMF coefficients E[P_l] = i_l(κ)/i_0(κ) (eq 19 is their large-κ approximation)."""
    mu, kappa, lmax = np.array([0.3, -0.2, 0.9]), 6.0, 6
    mu = mu / np.linalg.norm(mu)
    x = vmf_samples_stratified(mu, kappa, 64).reshape(64, 64, 3)
    gamma = sh.ndf_sh_pyramid(x, lmax)[-1][0, 0]
    d, w = polar_rule()
    # the quadrature's directions about μ instead of +z
    dd = d @ frame(mu).T
    quad = sh_eval(dd, lmax).T @ (w * vmf_pdf(dd, mu, kappa))
    np.testing.assert_allclose(gamma, quad, atol=2e-3)
    # zonal structure γ_lm = g_l Y_lm(μ)
    g = vmf_zonal_exact(kappa, lmax)
    per_k = np.repeat(g, 2 * np.arange(lmax + 1) + 1)
    np.testing.assert_allclose(quad, per_k * sh_eval(mu, lmax), atol=1e-9)
    # eq 19 (e^{−l²/2κ}) is a large-κ approximation: within 0.01 at κ = 200 for l ≤ 4, off by
    # 0.13 at κ = 6, l = 2 (the exact E[P_l] ≈ 1 − l(l+1)/(2κ): docs/HAN07.md)
    np.testing.assert_allclose(vmf_zonal_eq19(200.0, 4), vmf_zonal_exact(200.0, 4), atol=0.01)
    assert abs(vmf_zonal_eq19(kappa, 2)[2] - g[2]) > 0.1


def _direct_convolution(f, mu, kappa, omega):
    """∫ f(ω·n) vMF(n; μ, κ) dn by quadrature about μ."""
    d, w = polar_rule(n_beta=600, n_phi=512)
    n = d @ frame(mu).T
    dens = w * vmf_pdf(n, mu, kappa)
    return np.array([np.sum(dens * f(n @ o)) for o in omega])


@pytest.mark.parametrize("kind", ["blinn_phong", "lambert"])
def test_vmf_brdf_convolution_in_sh_vs_quadrature(kind):
    """Eq 11/12: ρ_eff(ω) = Σ ρ̂_l γ_lm Y_lm(ω) with γ_lm of a vMF NDF equals the direct
    integral ∫ f(ω·n) γ(n) dn."""
    mu, kappa = np.array([0.2, 0.1, 0.97]), 20.0
    mu /= np.linalg.norm(mu)
    if kind == "blinn_phong":
        s, lmax = 8.0, 40
        f = lambda u: blinn_phong_lobe(u, s)              # noqa: E731
        rho = sh.blinn_phong_coeffs(s, lmax)
    else:
        lmax = 60                                         # the kink needs many bands
        f = lambda u: np.maximum(u, 0.0)                  # noqa: E731
        rho = sh.lambert_coeffs(lmax)
    g = vmf_zonal_exact(kappa, lmax)
    gamma = np.repeat(g, 2 * np.arange(lmax + 1) + 1) * sh_eval(mu, lmax)
    th = np.linspace(0, 2.0, 9)
    omega = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    got = sh.effective_brdf(gamma, rho, omega)
    want = _direct_convolution(f, mu, kappa, omega)
    scale = want.max()
    np.testing.assert_allclose(got / scale, want / scale, atol=2e-3)
    # the zonal form Σ ρ̂_l g_l (2l+1)/(4π) P_l(ω·μ) is the same number
    zonal = [np.sum(rho * g * (2 * np.arange(lmax + 1) + 1) / (4 * math.pi)
                    * eval_legendre(np.arange(lmax + 1), o @ mu)) for o in omega]
    np.testing.assert_allclose(got, zonal, rtol=1e-9, atol=1e-12)


def test_blinn_phong_and_torrance_sparrow_rho_hat_match_the_papers_forms():
    """§5.1: Blinn–Phong ρ̂_l ≈ e^{−l²/(2s)} (within 0.035 for l ≤ 8 at s = 64; the exact
    values follow e^{−l(l+1)/(2s)} within 0.01); eq 18: Λ_l f_l = e^{−(σl)²} for small σ."""
    l = np.arange(9)
    bp = sh.blinn_phong_coeffs(64.0, 8)
    np.testing.assert_allclose(bp, np.exp(-l * l / 128.0), atol=0.035)
    np.testing.assert_allclose(bp, np.exp(-l * (l + 1) / 128.0), atol=0.01)
    ts = sh.torrance_sparrow_coeffs(0.08, 8)
    assert ts[0] == pytest.approx(1.0, abs=0.005)      # eq 18's lobe is unit to O(σ²)
    np.testing.assert_allclose(ts, np.exp(-(0.08 * l) ** 2), atol=0.04)
    np.testing.assert_allclose(ts / ts[0], np.exp(-0.08 ** 2 * l * (l + 1)), atol=0.005)
    assert sh.blinn_phong_coeffs(64.0, 0)[0] == pytest.approx(1.0, abs=1e-10)


def test_measured_table_reproduces_the_analytic_beckmann():
    """A tabulated D(θ_h) (MERL's θ_h bins, piecewise linear) of a Beckmann lobe gives the
    analytic Beckmann ρ̂_l; an sgpipe BRDF object (its NDF) gives the same."""
    alpha, lmax = 0.3, 10
    want = sh.beckmann_coeffs(alpha, lmax)
    d = sh.beckmann_ndf(np.cos(NDF_THETA), alpha)
    got = sh.tabulated_coeffs(NDF_THETA, d / d[0], lmax)
    np.testing.assert_allclose(got, want, rtol=5e-3, atol=1e-4)
    np.testing.assert_allclose(sh.brdf_coeffs(make_brdf("beckmann", {"alpha": alpha}), lmax),
                               want, rtol=1e-3, atol=1e-5)
    assert want[0] == pytest.approx(sh.zonal_coeffs(lambda u: sh.beckmann_ndf(u, alpha), 0)[0])
