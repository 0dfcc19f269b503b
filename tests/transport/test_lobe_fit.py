"""`transport.sampling: lobe` (sgpipe.transport.lobe_fit): the lobe samples integrate the
transport like brute-force quadrature, a sharp lobe keeps its energy (the light cube's texel
centres lose it), an occluder removes exactly its share and moves the Gaussian into the
visible part, and κ inverts the vMF's mean resultant length."""

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.transport.chunk import TransportTask, run_chunk
from sgpipe.transport.fit import FitOptions
from sgpipe.transport.interp import lobe_area
from sgpipe.transport.lobe_fit import (EXTRAPOLATE_COS, lobe_gaussians, lobe_samples,
                                       raised_views, sample_error, shadow_samples)
from sgpipe.transport.sampling import light_cube, vertex_transport, vertex_visibility
from sgpipe.transport.views import view_set
from tests.transport.test_sampling import frame, quadrature, slab_scene


@pytest.mark.parametrize("model,params", [
    ("ggx", {"alpha": 0.05, "ks": 1.0, "fresnel": "schlick", "f0": 0.5}),
    ("beckmann", {"alpha": 0.3, "ks": 0.8, "fresnel": "none"}),
    ("ward", {"alpha_u": 0.04, "alpha_v": 0.2, "ks": 0.7}),
])
def test_lobe_samples_integrate_like_quadrature(model, params):
    brdf = make_brdf(model, params)
    n, t, b = frame([0.3, 0.9, -0.2])
    views = view_set()[0]
    active = views @ n > 0.3
    dirs, wgt, q = lobe_samples(brdf, n, t, b, views, active, 256)
    assert np.allclose(np.linalg.norm(dirs, axis=-1), 1.0)
    assert np.all(wgt >= 0) and np.all((wgt > 0).any(-1) <= (q > 0))
    for a, v in list(enumerate(np.flatnonzero(active)))[::9]:
        ref = quadrature(brdf, n, t, b, views[v], res=768)
        assert np.allclose(wgt[a].sum(0), ref, rtol=0.02), (v, wgt[a].sum(0), ref)


def _task(model, params, sampling, scene=None, cube=16):
    opts = FitOptions(gaussians=1, sigma_min=np.radians(0.25 if sampling == "lobe" else
                                                        45.0 / cube), sigma_max=1.5)
    n, t, b = frame([0, 1, 0])
    return TransportTask(scene, np.array([0]), np.zeros((1, 3)), n[None], t[None], b[None],
                         [np.zeros(0, np.int64)], model, params, cube, 1e-4, opts,
                         float(np.sin(np.radians(1.0))), None, sampling, 128)


def _integrals(res):
    """(V,) luminance integral of each view's Gaussians."""
    return (res.w[0].mean(-1) * 2 * np.pi * lobe_area(res.sigma[0])).sum(-1)


def test_a_sharp_lobe_keeps_its_energy():
    """GGX α 0.03 is narrower than a 6×16² light texel (5.6°): fitted at the texel centres it
    loses energy; from the lobe samples each view's Gaussian carries the lobe's integral."""
    model, params = "ggx", {"alpha": 0.03, "ks": 1.0, "fresnel": "none"}
    brdf = make_brdf(model, params)
    views = view_set()[0]
    n, t, b = frame([0, 1, 0])
    check = np.flatnonzero(views @ n > 0.3)
    # the directional albedo by jittered 128² stratified NDF sampling (another estimator)
    loc = np.stack([views[check] @ t, views[check] @ b, views[check] @ n], -1)
    ref = brdf.albedo(loc, n=128, lobe="specular")[:, 0]
    lobe = _integrals(run_chunk(_task(model, params, "lobe")))[check]
    cube = _integrals(run_chunk(_task(model, params, "cube")))[check]
    assert np.allclose(lobe, ref, rtol=0.03), np.max(np.abs(lobe / ref - 1))
    assert np.max(np.abs(cube / ref - 1)) > 0.1


def test_occluder_removes_its_share_and_moves_the_lobe():
    """The slab hides ω_x > 0: a view in the plane x = 0 keeps exactly half of a symmetric
    lobe's samples' weight, and its Gaussian's mean moves to x < 0."""
    brdf = make_brdf("beckmann", {"alpha": 0.3, "ks": 1.0, "fresnel": "none"})
    n, t, b = frame([0, 1, 0])
    views = np.array([[0.0, np.cos(a), np.sin(a)] for a in (0.0, 0.4, -0.9)])
    active = np.ones(3, bool)
    dirs, wgt, _ = lobe_samples(brdf, n, t, b, views, active, 512)
    occ = shadow_samples(slab_scene(), np.zeros(3), n, dirs, wgt, 1e-4)
    assert np.array_equal(occ > 0, (wgt > 0) & (dirs[..., :1] < 0))
    full, half = wgt.sum(1), occ.sum(1)
    # the lattice is not mirror symmetric in x: half within its quadrature error
    assert np.allclose(half, 0.5 * full, rtol=0.03)
    mu0, _, _ = lobe_gaussians(dirs, wgt, views, active, 0.005, 1.5)
    mu1, s1, w1 = lobe_gaussians(dirs, occ, views, active, 0.005, 1.5)
    assert np.all(np.abs(mu0[:, 0, 0]) < 0.02) and np.all(mu1[:, 0, 0] < -0.1)
    integ = w1[:, 0] * (2 * np.pi * lobe_area(s1[:, 0]))[:, None]
    assert np.allclose(integ, half, rtol=1e-12)


def test_lobe_fit_through_the_chunk_is_deterministic_and_horizon_safe():
    """Two runs give the same bytes; views down to 60° below the horizon carry the Gaussian
    of their view raised to the horizon, views further below zero weight; every weight is
    finite and ≥ 0."""
    a = run_chunk(_task("ggx", {"alpha": 0.1, "ks": 0.9}, "lobe", cube=8))
    b = run_chunk(_task("ggx", {"alpha": 0.1, "ks": 0.9}, "lobe", cube=8))
    assert np.array_equal(a.w, b.w) and np.array_equal(a.mu, b.mu)
    views = view_set()[0]
    n, t, _ = frame([0, 1, 0])
    min_cos = float(np.sin(np.radians(1.0)))
    far = views[:, 1] <= EXTRAPOLATE_COS
    raised = (views[:, 1] <= min_cos) & ~far
    assert not a.w[0][far].any() and a.w[0][raised].all()
    up = raised_views(views, n, t, min_cos)
    assert np.allclose(up[raised] @ n, min_cos) and np.array_equal(up[~raised & ~far],
                                                                   views[~raised & ~far])
    # turned in its own vertical plane: the horizontal direction is kept
    h = lambda v: (v - np.outer(v @ n, n)) / np.linalg.norm(v - np.outer(v @ n, n), axis=1,
                                                             keepdims=True)
    assert np.allclose(h(up[raised]), h(views[raised]))
    assert np.all(np.isfinite(a.w)) and np.all(a.w >= 0)
    assert np.allclose(np.linalg.norm(a.mu[0], axis=-1), 1.0)
    assert a.fitted == 1 and 0 < a.rel_err[0] < 1


def _view_fit(brdf, n, t, b, v, k, samples=512):
    active = np.ones(len(v), bool)
    dirs, wgt, q = lobe_samples(brdf, n, t, b, v, active, samples)
    g = lobe_gaussians(dirs, wgt, v, active, np.radians(0.25), 1.5, k, n)
    return g, sample_error(dirs, wgt, q, *g, active), wgt.sum(1)


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_every_form_carries_the_integral(k):
    brdf = make_brdf("ggx", {"alpha": 0.06, "ks": 0.9, "fresnel": "none"})
    n, t, b = frame([0.2, 1.0, 0.1])
    v = np.array([[0.0, 1.0, 0.0], [0.6, 0.6, 0.2], [-0.9, 0.3, 0.1]])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    (mu, sig, w), err, integral = _view_fit(brdf, n, t, b, v, k)
    assert mu.shape == (3, k, 3) and np.all(w >= 0) and 0 < err < 1
    got = (w * (2 * np.pi * lobe_area(sig))[..., None]).sum(1)
    assert np.allclose(got, integral, rtol=1e-9)


def test_sublobes_follow_an_anisotropic_lobe():
    """Ward α 0.04 × 0.2 seen head-on: the lobe is five times longer along the bitangent; the
    three sub-lobes line up along it and fit it better than one Gaussian."""
    brdf = make_brdf("ward", {"alpha_u": 0.04, "alpha_v": 0.2, "ks": 0.8})
    n, t, b = frame([0, 1, 0])
    v = n[None]
    (mu, sig, w), err3, _ = _view_fit(brdf, n, t, b, v, 3)
    _, err1, _ = _view_fit(brdf, n, t, b, v, 1)
    d = mu[0, 2] - mu[0, 0]
    assert abs(d @ b) / np.linalg.norm(d) > 0.95
    assert err3 < 0.7 * err1, (err3, err1)


def test_a_halo_takes_the_ggx_tail():
    """GGX α 0.05's long tail: with a halo the error is lower than with one lobe and the halo
    carries part of the integral."""
    brdf = make_brdf("ggx", {"alpha": 0.05, "ks": 0.9, "fresnel": "none"})
    n, t, b = frame([0, 1, 0])
    v = np.array([[0.0, 0.8, 0.6]])
    (mu, sig, w), err2, integral = _view_fit(brdf, n, t, b, v, 2)
    _, err1, _ = _view_fit(brdf, n, t, b, v, 1)
    assert sig[0, 1] > 1.4 * sig[0, 0] and w[0, 1, 0] > 0
    assert err2 < 0.9 * err1, (err2, err1)


def test_cube_sampling_still_fits_on_the_light_cube():
    """The published path is untouched by the lobe option: `sampling: cube` matches
    vertex_transport's texel data (the fit's weights integrate to the texel sums within the
    fit's error)."""
    model, params = "beckmann", {"alpha": 0.3, "ks": 1.0, "fresnel": "none"}
    res = run_chunk(_task(model, params, "cube"))
    brdf = make_brdf(model, params)
    cube = light_cube(16)
    n, t, b = frame([0, 1, 0])
    views = view_set()[0]
    vis = vertex_visibility(None, np.zeros(3), n, cube.dirs, 0.0)
    T, active = vertex_transport(brdf, n, t, b, views, cube, vis, float(np.sin(np.radians(1))))
    texel = (T.mean(-1) * cube.omega).sum(-1)
    check = np.flatnonzero(views @ n > 0.3)
    assert np.allclose(_integrals(res)[check], texel[check], rtol=0.1)
