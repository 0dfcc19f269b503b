"""The SG ↔ GGX lobe mapping against quadrature that shares no code with the fit."""

import numpy as np
import pytest

from sgpipe.core.quadrature import gauss_legendre, lobe_quadrature
from sgpipe.core.sg import sg_inner, sg_integral
from sgpipe.export import ggx_mapping as gm

AXIS = np.array([0.3, 0.5, -0.81])
AXIS = AXIS / np.linalg.norm(AXIS)


def test_roughness_of_level_is_level_over_levels_minus_one():
    assert [gm.roughness_of_level(m, 7) for m in range(7)] == pytest.approx(
        [0, 1 / 6, 2 / 6, 3 / 6, 4 / 6, 5 / 6, 1])
    assert gm.alpha_of_roughness(0.5) == 0.25


@pytest.mark.parametrize("alpha", [0.03, 0.2, 0.6, 1.0])
def test_ggx_ndf_is_normalised_over_the_half_vectors(alpha):
    d, w = lobe_quadrature(AXIS, 1.0 / alpha ** 2, n_per_panel=32, n_phi=8, hemisphere=True)
    c = d @ AXIS
    assert (gm.ggx_ndf(c, alpha) * c * w).sum() == pytest.approx(1.0, abs=2e-5)


@pytest.mark.parametrize("alpha", [0.01, 0.1, 0.4, 1.0])
def test_lobe_integral_matches_the_half_vector_integral(alpha):
    """∫ K_α dl (zonal rule in θ = ∠(r, l)) = ∫ D(h)(n·l)⁺ 4(n·h) dh (rule in h, l = 2(n·h)h − n:
    the reflection Jacobian dl = 4(v·h) dh with v = n)."""
    smax = 1.0 - np.sqrt(0.5)                     # n·l > 0 ⇔ n·h > 1/√2
    edges = [0.0, *[e for e in alpha ** 2 / 4 * 4.0 ** np.arange(12) if e < smax], smax]
    h_side = 0.0
    for a, b in zip(edges[:-1], edges[1:]):      # panels in s = 1 − n·h, azimuth exact (2π)
        s, ws = gauss_legendre(24, a, b)
        c = 1.0 - s
        h_side += (gm.ggx_ndf(c, alpha) * (2 * c * c - 1) * 4 * c * ws).sum() * 2 * np.pi
    assert gm.ggx_lobe_integral(alpha) == pytest.approx(h_side, rel=1e-8)


def _l2_on_sphere(alpha, f):
    """‖f − K̂_α‖/‖K̂_α‖ by a 3-D lobe-graded rule about AXIS (K̂ normalised by the same rule)."""
    d, w = lobe_quadrature(AXIS, 1.0 / alpha ** 2, n_per_panel=48, n_phi=16)
    c = d @ AXIS
    k = gm.ggx_lobe(c, alpha)
    k = k / (k * w).sum()
    return np.sqrt(((f(c) - k) ** 2 * w).sum() / (k * k * w).sum())


@pytest.mark.parametrize("alpha", [0.004, 0.03, 0.1, 0.25])
def test_four_sg_mixture_fits_the_ggx_lobe(alpha):
    mix = gm.fit_sg_mixture(alpha)
    assert min(mix.weights) >= 0 and sum(mix.weights) == pytest.approx(1.0, abs=1e-12)
    assert list(mix.lambdas) == sorted(mix.lambdas)
    independent = _l2_on_sphere(alpha, mix)
    assert independent == pytest.approx(mix.rel_l2, rel=0.05, abs=2e-4)
    assert independent < 0.005
    d, w = lobe_quadrature(AXIS, 1.0 / alpha ** 2, n_per_panel=48, n_phi=16)
    assert (mix(d @ AXIS) * w).sum() == pytest.approx(1.0, abs=1e-6)     # unit integral


def test_one_sg_is_not_enough_and_the_mapping_tends_to_0_40_over_alpha_squared():
    """The single-lobe mapping for reference: λ ≈ 0.40/α², 23 % off in L2 (GGX's θ⁻⁴ tail)."""
    for alpha in (0.005, 0.01):
        lam = gm.single_sg_sharpness(alpha)
        assert lam * alpha ** 2 == pytest.approx(0.404, abs=0.01)
        err = _l2_on_sphere(alpha, lambda c: gm.sg_normalised(c, lam))
        assert 0.2 < err < 0.25


def test_past_alpha_0_3_the_mixture_is_worse_than_one_percent():
    """Where the exporter switches to direct quadrature (the hemisphere cut-off)."""
    assert gm.fit_sg_mixture(0.25).rel_l2 <= gm.MAX_MIXTURE_REL_L2
    assert gm.fit_sg_mixture(0.45).rel_l2 > gm.MAX_MIXTURE_REL_L2
    assert gm.fit_sg_mixture(1.0).rel_l2 > 0.1


@pytest.mark.parametrize("alpha", [0.05, 0.15, 0.25])
def test_mixture_prefilters_an_sg_light_like_ggx(alpha):
    """L(ω) = e^{μ(ω·c − 1)}: Σ_j w_j ⟨Ĝ_λj(·; r), L⟩ (closed form, Wang09 eq 6) against the
    GGX prefilter ∫ K̂_α(r·ω) L(ω) dω by quadrature, at r from the centre to the tail."""
    c, mu = AXIS, 80.0
    mix = gm.fit_sg_mixture(alpha)
    e1 = np.cross(c, [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    peak = None
    for ang in (0.0, 0.5 * alpha, 2 * alpha, 4 * alpha):
        r = np.cos(ang) * c + np.sin(ang) * e1
        d, w = lobe_quadrature(r, 1.0 / alpha ** 2, n_per_panel=48, n_phi=64)
        k = gm.ggx_lobe(d @ r, alpha)
        ggx = (k * np.exp(mu * (d @ c - 1)) * w).sum() / (k * w).sum()
        sg = sum(wj * float(sg_inner(r, lj, 1.0, c, mu, 1.0)) / sg_integral(lj, 1.0)
                 for wj, lj in zip(mix.weights, mix.lambdas))
        peak = ggx if peak is None else peak
        assert abs(sg - ggx) < 0.01 * peak, (ang, sg, ggx)
