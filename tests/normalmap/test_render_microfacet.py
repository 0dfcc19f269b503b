"""Torrance–Sparrow (Cook–Torrance, Gaussian in θ_h) and Beckmann materials in the normal-map
kernels (nm_shade.h): one vMF lobe through eq 21 against quadrature of the BRDF over the vMF
NDF (eq 5); the baselines' roughness formulas against numpy; the finest level against the
reference's BRDF in the normal-mapped frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid
from sgpipe.normalmap.pyramid import mean_normal_pyramid
from sgpipe.reference.surface import mapped_view, normal_mapped_frame
from sgpipe.render.normalmap_data import NormalMapPyramid
from tests.normalmap.render_mirror import (banerjee_kappa, convolved_roughness, directional,
                                           flat_frame, ggx_conv_lobes, material,
                                           microfacet_lobe, one_lobe_error, renderer,
                                           single_lobe_pyramid, unit)

MU = unit([0.25, -0.1, 1.0])
LIGHT = unit([0.3, -0.2, 0.9])


def _views(n, seed, spread=0.12):
    """Views around the mirror direction of the light about MU (where the lobe is)."""
    rng = np.random.default_rng(seed)
    r = 2 * (LIGHT @ MU) * MU - LIGHT
    return unit(r + rng.normal(0, spread, (n, 3)))


def _big_footprint(n):
    duv = np.zeros((n, 4), np.float32)
    duv[:, 0] = duv[:, 3] = 8.0          # clamped to the top (1×1) level
    return duv


@pytest.mark.parametrize("model,a,kappa,tol", [
    ("beckmann", 0.1, 100.0, 0.03), ("beckmann", 0.3, 100.0, 0.05),
    ("beckmann", 0.2, 20.0, 0.05), ("beckmann", 0.1, 400.0, 0.015),
    ("cook_torrance", 0.2, 100.0, 0.015), ("cook_torrance", 0.2, 20.0, 0.025),
    ("ggx", 0.1, 100.0, 0.015), ("ggx", 0.2, 20.0, 0.025), ("ggx", 0.3, 100.0, 0.012),
    ("ggx", 0.05, 1000.0, 0.005), ("ggx", 0.4, 10.0, 0.05), ("gltf_pbr", 0.15, 100.0, 0.01)])
def test_vmf_lobe_eq21_matches_quadrature(model, a, kappa, tol):
    """Kernel `vmf` with one lobe (μ, κ) vs ∫ vMF(n) ρ(o, i; n) (n·i) dn, per pixel, relative
    to the peak of each view's lobe. Measured max (mean): Beckmann α 0.1 κ 100 0.017 (0.006),
    α 0.3 κ 100 0.037 (0.032), α 0.2 κ 20 0.040 (0.028), α 0.1 κ 400 0.007 (0.003);
    Cook–Torrance m 0.2 κ 100 0.006 (0.004), κ 20 0.012 (0.007): eq 21's error (float32 is
    far below). GGX (D: its SG lobes each convolved with the vMF, nm_ggx_conv_lobes; G at the
    peak-matched α′ of core.ggx_conv): α 0.1 κ 100 0.009 (0.003), α 0.2 κ 20 0.018
    (0.013), α 0.3 κ 100 0.007 (0.006), α 0.05 κ 1000 0.002 (0.001), α 0.4 κ 10 0.045
    (0.043); glTF (height-correlated G2) α 0.15 κ 100 0.006 (0.003). One GGX of the
    peak-matched α′ in place of the lobes errs 0.087, 0.030, 0.020, 0.086, 0.043 (a GGX
    convolved with a vMF is no GGX: its core takes the vMF's shape), and Beckmann's rule
    α′² = α² + 2/κ +0.15 … +0.22."""
    brdf, _ = material(model, a)
    rend = renderer(model, a, single_lobe_pyramid(MU, kappa), lights=[directional(LIGHT)])
    err, ref = one_lobe_error(rend, brdf, MU, kappa, _views(8, 1), LIGHT, _big_footprint(8))
    assert ref.max() > 0.02
    assert err.max() < tol, (err.max(), ref)


@pytest.mark.parametrize("model,a", [("beckmann", 0.15), ("cook_torrance", 0.25), ("ggx", 0.15),
                                     ("gltf_pbr", 0.2)])
@pytest.mark.parametrize("method", ["vmf", "normals_mip", "toksvig", "engine_bake"])
def test_roughness_of_each_method(model, a, method):
    """The one lobe each method shades at the top level (mean length r = A(κ)): vmf eq 21 at
    the stored κ (GGX: its SG lobes convolved, G at the table's α′); normals_mip α; toksvig
    α′² = α² + 2(1 − r)/r; engine_bake κ(r), α′² = α² + 2/κ as engines widen GGX too."""
    kappa = 60.0
    n = 10
    views = _views(n, 2, 0.2)
    fr = flat_frame(views, np.full((n, 2), 0.7), _big_footprint(n))
    img = renderer(model, a, single_lobe_pyramid(MU, kappa), lights=[directional(LIGHT)]
                   ).shade(method, fr)[:, 0]
    r = 1 / math.tanh(kappa) - 1 / kappa
    lobes = None
    if method == "vmf" and model in ("ggx", "gltf_pbr"):
        # GGX: D from its SG lobes convolved with the vMF, G at the peak-matched α′
        from sgpipe.core.ggx_conv import convolved_a2
        ap, amp = math.sqrt(float(convolved_a2(a, kappa))), 1.0
        lobes = ggx_conv_lobes(a, kappa)
    elif method == "vmf":
        ap, amp = convolved_roughness(a, kappa)
    elif method == "normals_mip":
        ap, amp = a, 1.0
    elif method == "toksvig":
        a2 = a * a + 2 * (1 - r) / r
        ap, amp = math.sqrt(a2), a * a / a2
    else:
        ap, amp = convolved_roughness(a, banerjee_kappa(r))
    ref = np.array([microfacet_lobe(model, ap, amp, MU, o, LIGHT, lobes) for o in views])
    assert ref.max() > 0.1
    np.testing.assert_allclose(img, ref, rtol=2e-3, atol=1e-5 * ref.max())


@pytest.mark.parametrize("model,a", [("beckmann", 0.2), ("cook_torrance", 0.3), ("ggx", 0.2),
                                     ("gltf_pbr", 0.25)])
def test_finest_level_equals_the_reference_brdf(model, a):
    """Level 0 at texel centres (κ = 10⁶ lobes): the reference's BRDF (Fresnel included) in
    the texel's normal-mapped frame (sgpipe.reference.surface), every method."""
    side = 8
    rng = np.random.default_rng(3)
    nrm = np.concatenate([rng.normal(0, 0.3, (side, side, 2)), np.ones((side, side, 1))], -1)
    nrm = unit(nrm)
    p = fit_vmf_pyramid(nrm, VMFSettings(lobes=1, kappa_max=1e6))
    pyr = NormalMapPyramid(p.alpha, p.alpha_r,
                           [m.astype(np.float32) for m in mean_normal_pyramid(nrm)])
    n = 30
    ij = rng.integers(0, side, (n, 2))
    uv = np.stack([(ij[:, 1] + 0.5) / side, 1 - (ij[:, 0] + 0.5) / side], -1)
    views = _views(n, 4, 0.4)
    views[:, 2] = np.abs(views[:, 2]) + 0.05
    views = unit(views)
    fr = flat_frame(views, uv, np.zeros((n, 4)))
    brdf, _ = material(model, a, fresnel="schlick")
    one = lambda v: np.tile(v, (n, 1)).astype(float)  # noqa: E731
    t, b, nz = one([1.0, 0, 0]), one([0, 1.0, 0]), one([0, 0, 1.0])
    t2, b2, n2 = normal_mapped_frame(t, b, nz, (nrm[ij[:, 0], ij[:, 1]] + 1) / 2)
    view = mapped_view(views, t, b, nz, t2, b2, n2)
    loc = lambda d: np.stack([np.sum(d * t2, 1), np.sum(d * b2, 1), np.sum(d * n2, 1)], -1)  # noqa
    il = loc(np.tile(LIGHT, (n, 1)))
    ref = np.where(il[:, 2:3] > 0, brdf.eval(loc(view), il) * il[:, 2:3], 0.0)
    assert ref.max() > 0.005
    for method in ("vmf", "normals_mip", "toksvig", "engine_bake"):
        img = renderer(model, a, pyr, lights=[directional(LIGHT)], fresnel="schlick"
                       ).shade(method, fr)
        np.testing.assert_allclose(img, ref, rtol=3e-3, atol=1e-5 * ref.max(), err_msg=method)


def test_ggx_convolution_table():
    """The stored table and GGX lobes are build_table's and build_lobes' (regenerable: `python
    -m sgpipe.core.ggx_conv`), and the kernels' bilinear α′² is within
    2 % of the exact sphere-peak α′² at 60 random (α 0.005–1, σ/α 0.06–10) off the nodes
    (median 0.01 %); the peak itself against a direct product-rule quadrature."""
    from sgpipe.core import ggx_conv as g
    np.testing.assert_allclose(g.load_table(), g.build_table(), atol=1e-6)
    for stored, built in zip(g.load_lobes(), g.build_lobes()):
        np.testing.assert_allclose(stored, built, rtol=1e-6)
    rng = np.random.default_rng(4)
    errs = []
    for _ in range(60):
        a = math.exp(rng.uniform(math.log(0.005), 0.0))
        kappa = 1.0 / (a * math.exp(rng.uniform(math.log(0.06), math.log(10.0)))) ** 2
        errs.append(float(g.convolved_a2(a, kappa)) / g.sphere_a2(a, kappa) - 1.0)
    assert np.max(np.abs(errs)) < 0.02 and np.median(np.abs(errs)) < 1e-3
    # the peak: Gauss–Legendre on θ ∈ [0, π/2] in 4 panels split at the lobes' widths
    for a, kappa in ((0.1, 100.0), (0.5, 4.0), (0.02, 1e4)):
        edges = np.unique(np.clip([0.0, a, 3 * a, 3 / math.sqrt(kappa), math.pi / 2],
                                  0.0, math.pi / 2))
        x, w = np.polynomial.legendre.leggauss(400)
        total = 0.0
        for lo, hi in zip(edges[:-1], edges[1:]):
            t = lo + (hi - lo) * (x + 1) / 2
            f = (kappa / (2 * math.pi * -math.expm1(-2 * kappa)) * np.exp(kappa * (np.cos(t) - 1))
                 * g.ggx_d(np.cos(t), a) * 2 * math.pi * np.sin(t))
            total += (hi - lo) / 2 * np.sum(w * f)
        assert g.convolved_peak(a, kappa) == pytest.approx(total, rel=1e-6)
