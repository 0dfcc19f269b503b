"""Per-view vMF mixtures (Töral19 §IV): accuracy, amplitudes, colours, coherence, layout."""

from __future__ import annotations

import numpy as np
import pytest

from sgpipe.brdf import LUMINANCE, make_brdf
from sgpipe.fit.view_gmm import fit_view_gmm, interpolation_errors, lobe_curve


@pytest.mark.parametrize("alpha", [0.05, 0.1, 0.2])
def test_ward_8_lobes_below_10_percent_up_to_60_degrees(alpha):
    brdf = make_brdf("ward", {"alpha": alpha})
    gmm = fit_view_gmm(brdf, n_theta=5, theta_max=np.radians(60.0), n_lobes=8)
    assert gmm.rel_l2.shape == (5,)
    assert np.all(gmm.rel_l2 < 0.10), gmm.rel_l2


def test_error_falls_with_lobe_count():
    brdf = make_brdf("ward", {"alpha": 0.1})
    curve = lobe_curve(brdf, np.radians([30.0, 60.0]), 8)
    assert np.all(curve[:, -1] < 0.5 * curve[:, 0]), curve
    assert curve[1, -1] < 0.2 * curve[1, 0]                     # grazing slice: strongly
    assert np.all(np.min(curve[:, :4], 1) >= np.min(curve[:, 4:], 1) - 0.01)


def test_amplitudes_match_the_slice_integral():
    brdf = make_brdf("ggx", {"alpha": 0.2, "ks": [0.9, 0.6, 0.3]})
    gmm = fit_view_gmm(brdf, n_theta=3, theta_max=np.radians(50.0), n_lobes=4, errors=False)
    np.testing.assert_allclose(gmm.alpha.sum(axis=1), gmm.albedo, rtol=1e-12)
    mc = brdf.albedo(gmm.view_dirs, n=128, lobe="specular")
    np.testing.assert_allclose(gmm.albedo, mc, rtol=0.01)


def test_lobe_colours_follow_diffuse_and_specular_eq22():
    brdf = make_brdf("ward", {"alpha": 0.05, "kd": [0.6, 0.0, 0.0], "ks": [0.0, 0.0, 0.4]})
    gmm = fit_view_gmm(brdf, n_theta=2, theta_max=np.radians(40.0), n_lobes=6,
                       include_diffuse=True, errors=False)
    for j in range(2):
        sharp = int(np.argmax(gmm.kappa[j]))
        broad = int(np.argmin(gmm.kappa[j]))
        assert gmm.alpha[j, sharp, 2] > 5 * gmm.alpha[j, sharp, 0]
        assert gmm.alpha[j, broad, 0] > 5 * gmm.alpha[j, broad, 2]


def test_coherent_fits_interpolate_better_than_independent():
    brdf = make_brdf("ward", {"alpha": 0.2})
    kw = dict(n_theta=7, theta_max=np.radians(75.0), n_lobes=8, errors=False)
    coh = fit_view_gmm(brdf, coherent=True, **kw)
    ind = fit_view_gmm(brdf, coherent=False, **kw)
    _, e_coh = interpolation_errors(brdf, coh)
    _, e_ind = interpolation_errors(brdf, ind)
    assert e_coh.mean() < 0.6 * e_ind.mean(), (e_coh, e_ind)
    # lobe k moves smoothly: neighbouring views' matching lobes stay close
    step = np.einsum("jkc,jkc->jk", coh.mu[1:], coh.mu[:-1])
    assert np.median(step) > np.cos(np.radians(20.0))


def test_texture_layout_and_relative_azimuth(tmp_path):
    from sgpipe.artifacts import FolderSink
    from sgpipe.artifacts import fit as art
    from sgpipe.io import read_exr
    brdf = make_brdf("ggx", {"alpha_u": 0.1, "alpha_v": 0.3})
    gmm = fit_view_gmm(brdf, n_theta=3, n_phi=4, theta_max=np.radians(60.0), n_lobes=3,
                       n_samples=1024, errors=False)
    art.write_view_gmm(FolderSink(tmp_path), "m", gmm.arrays(), view_theta_max=np.radians(60))
    tex = read_exr(tmp_path / art.material_file("m", art.VIEW_GMM_TEXTURE), channels=(6,))
    assert tex.shape == (3, 4 * 3, 6)
    arr = gmm.arrays()
    t, p, k = 2, 3, 1
    j = t * 4 + p
    np.testing.assert_allclose(tex[t, p * 3 + k, :3], arr["alpha"][j, k], rtol=1e-6)
    assert tex[t, p * 3 + k, 3] == pytest.approx(arr["kappa"][j, k], rel=1e-6)
    assert tex[t, p * 3 + k, 4] == pytest.approx(arr["mu_phi"][j, k], abs=1e-6)
    np.testing.assert_allclose(arr["view_dirs"][j], [np.sin(np.pi / 3) * np.cos(1.5 * np.pi),
                                                    np.sin(np.pi / 3) * np.sin(1.5 * np.pi),
                                                    np.cos(np.pi / 3)], atol=1e-6)
    # strongest lobe of an oblique view sits near the mirror azimuth: |mu_phi| small
    top = np.argmax(arr["alpha"][4:] @ LUMINANCE, axis=1)
    assert np.all(np.abs(arr["mu_phi"][4:][np.arange(8), top]) < 0.6)
    phi_abs = np.arctan2(arr["mu"][..., 1], arr["mu"][..., 0])
    ref = np.repeat(arr["view_phi"][None], 3, 0).ravel()[:, None] + np.pi + arr["mu_phi"]
    np.testing.assert_allclose(np.cos(phi_abs - ref), 1.0, atol=1e-5)
