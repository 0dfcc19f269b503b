"""Carrying per-view vMF mixtures to views between the fitted ones (sgpipe.fit.view_gmm
warp_lobes, the Python mirror of gmm_shade.cl warp_half): exact for a lobe fixed in half-vector
space, and closer to the true slice than a rigid rotation of the mirror direction."""

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.fit.view_gmm import fit_view_gmm, nearest_view_errors, warp_lobes


def _dir(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def _reflect(o, h):
    return 2.0 * (o @ h) * h - o


def test_warp_moves_a_lobe_fixed_in_half_vector_space_exactly():
    """A lobe of half-vector axis h0 and width κ_h seen from o has axis reflect(o, h0) and
    κ = κ_h / (4 o·h0) (reflection Jacobian): carried from view a to view b it is b's lobe."""
    h0 = _dir(12.0, 70.0)
    kappa_h = 400.0
    for a, b in [((10, 0), (30, 40)), ((50, 90), (60, 120)), ((0, 0), (45, 200))]:
        oa, ob = _dir(*a), _dir(*b)
        mu_a = _reflect(oa, h0)[None]
        k_a = np.array([kappa_h / (4 * oa @ h0)])
        mu, k = warp_lobes(oa, ob, mu_a, k_a)
        np.testing.assert_allclose(mu[0], _reflect(ob, h0), atol=1e-12)
        np.testing.assert_allclose(k[0], kappa_h / (4 * ob @ h0), rtol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(mu[0]), 1.0, atol=1e-12)


def test_warp_to_the_same_view_is_the_identity():
    rng = np.random.default_rng(1)
    o = _dir(40.0, 10.0)
    mu = rng.normal(size=(6, 3))
    mu /= np.linalg.norm(mu, axis=1, keepdims=True)
    mu[:, 2] = np.abs(mu[:, 2])
    k = rng.uniform(1, 1e3, 6)
    m2, k2 = warp_lobes(o, o, mu, k)
    np.testing.assert_allclose(m2, mu, atol=1e-12)
    np.testing.assert_allclose(k2, k, rtol=1e-12)


@pytest.fixture(scope="module")
def aniso_fit():
    b = make_brdf("beckmann", {"alpha_u": 0.05, "alpha_v": 0.25, "ks": 1.0, "kd": 0.0,
                               "fresnel": "none"})
    return b, fit_view_gmm(b, n_theta=6, n_phi=4, n_lobes=12, n_samples=2048,
                           theta_max=np.radians(75), errors=False)


def test_anisotropic_slice_between_azimuth_views_warp_beats_rotation(aniso_fit):
    """5:1 Beckmann on a 4-azimuth grid, views 45° from the nearest grid azimuth (the φ cell
    border, where the renderer switched views and banded): the half-vector warp keeps the
    lobe's orientation in the tangent frame; the rigid rotation turns it with the view.
    Measured: mean relative L2 0.11 (warp) vs 0.40 (rotate) vs 1.0 (no carry)."""
    b, g = aniso_fit
    views = np.array([_dir(t, p) for t in (20, 35, 50) for p in (45, 135, 30)])
    warp = nearest_view_errors(b, g, views, "warp")
    rot = nearest_view_errors(b, g, views, "rotate")
    none = nearest_view_errors(b, g, views, "none")
    assert warp.mean() < 0.5 * rot.mean(), (warp, rot)
    assert rot.mean() < none.mean()
    assert warp.max() < 0.3, warp


def test_isotropic_slice_between_elevation_views_warp_beats_rotation():
    """GGX α 0.1 on a 15° θ grid, held out halfway: the warp also reshapes the lobe with θ
    (κ by the Jacobian, the off-specular shift) where the rotation only moves it.
    Measured: 0.054 (warp) vs 0.091 (rotate) mean relative L2."""
    b = make_brdf("ggx", {"alpha": 0.1, "ks": 1.0, "kd": 0.0, "fresnel": "none"})
    g = fit_view_gmm(b, n_theta=6, n_lobes=8, n_samples=2048, theta_max=np.radians(75),
                     errors=False)
    views = np.array([_dir(t, 57.0) for t in (7.5, 22.5, 37.5, 52.5, 67.5)])
    warp = nearest_view_errors(b, g, views, "warp")
    rot = nearest_view_errors(b, g, views, "rotate")
    assert warp.mean() < 0.8 * rot.mean(), (warp, rot)
    assert np.all(warp < rot + 0.01), (warp, rot)


def test_anisotropic_lobes_option_applies_to_anisotropic_brdfs_only():
    iso = make_brdf("ggx", {"alpha": 0.2, "ks": 1.0, "kd": 0.0})
    an = make_brdf("ggx", {"alpha_u": 0.1, "alpha_v": 0.3, "ks": 1.0, "kd": 0.0})
    kw = dict(n_theta=2, n_phi=2, n_lobes=3, n_samples=256, max_iter=5, errors=False,
              anisotropic_lobes=5)
    assert fit_view_gmm(iso, **kw).n_lobes == 3
    assert fit_view_gmm(an, **kw).n_lobes == 5
    kw["anisotropic_lobes"] = 0
    assert fit_view_gmm(an, **kw).n_lobes == 3
