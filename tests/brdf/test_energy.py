"""White-furnace style energy checks and microfacet identities (by quadrature)."""

from __future__ import annotations

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.brdf.shadowing import smith_g1_beckmann, smith_g1_ggx
from sgpipe.core.quadrature import hemisphere_quadrature, lobe_quadrature
from sgpipe.fit.ndf_sg import slope_quadrature

THETAS = np.radians([0.0, 30.0, 60.0, 80.0])
VIEWS = np.stack([np.sin(THETAS) * np.cos(0.3), np.sin(THETAS) * np.sin(0.3), np.cos(THETAS)], -1)


def _albedo_quadrature(brdf, o):
    """∫ ρ(o,i) cos θ_i di on a dense lobe-graded rule about the mirror direction + hemisphere."""
    r = o * np.array([-1.0, -1.0, 1.0])
    x, w = lobe_quadrature(r, 400.0, n_per_panel=24, n_phi=256)
    return w @ (brdf.eval(o, x) * np.maximum(x[:, 2], 0)[:, None])


PHYSICAL = [("lambert", {"kd": 1.0}), ("blinn_phong", {"exponent": 1}),
            ("blinn_phong", {"exponent": 200}), ("cook_torrance", {"m": 0.3, "fresnel": "none"}),
            ("ward", {"alpha": 0.1}), ("ward", {"alpha_u": 0.05, "alpha_v": 0.2}),
            ("beckmann", {"alpha": 0.5, "fresnel": "none"}),
            ("ggx", {"alpha": 1.0, "fresnel": "none"}), ("ggx", {"alpha_u": 0.1, "alpha_v": 0.6}),
            ("ashikhmin_shirley", {"nu": 10, "nv": 100, "rs": 1.0}),
            ("ashikhmin_shirley", {"nu": 100, "nv": 100, "rs": 0.0, "rd": 1.0, "ks": 0.0})]


@pytest.mark.parametrize("model,params", PHYSICAL, ids=[m for m, _ in PHYSICAL])
def test_white_furnace_albedo_at_most_one(model, params):
    b = make_brdf(model, params)
    mc = b.albedo(VIEWS, n=96)
    for o, a in zip(VIEWS, mc):
        q = _albedo_quadrature(b, o)
        assert np.all(q <= 1.0 + 2e-3), (o, q)
        np.testing.assert_allclose(a, q, rtol=0.02, atol=2e-3)   # sampler/pdf vs quadrature


def test_lambert_furnace_is_exactly_one():
    b = make_brdf("lambert", {"kd": 1.0})
    x, w = hemisphere_quadrature(64, 64)
    np.testing.assert_allclose(w @ (b.eval(np.array([0.2, 0.1, 0.97]) / np.linalg.norm(
        [0.2, 0.1, 0.97]), x) * x[:, 2:3]), 1.0, rtol=1e-10)


@pytest.mark.parametrize("name,g1", [("ggx", smith_g1_ggx), ("beckmann", smith_g1_beckmann)])
@pytest.mark.parametrize("au,av", [(0.3, 0.3), (0.1, 0.4)])
def test_smith_masking_identity(name, g1, au, av):
    """∫ G1(v) max(0, v·h) D(h) dh = cos θ_v for the normalised NDF (projected area)."""
    ndf = make_brdf(name, {"alpha_u": au, "alpha_v": av}).ndf_model
    h, w = slope_quadrature(au, av, extent=5000.0, resolution=6.0)
    d = ndf.eval(h) / (np.pi * au * av)
    assert w @ (d * h[:, 2]) == pytest.approx(1.0, rel=2e-3)          # ∫ D cos = 1
    for th, ph in ((0.3, 0.2), (1.0, 1.1), (1.3, 2.0)):
        v = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
        lhs = g1(v[None], au, av)[0] * (w @ (np.maximum(h @ v, 0.0) * d))
        assert lhs == pytest.approx(np.cos(th), rel=3e-3)


def test_as_sampling_density_integrates_to_one():
    ndf = make_brdf("ashikhmin_shirley", {"nu": 30, "nv": 600}).ndf_model
    h, w = slope_quadrature(np.sqrt(2 / 32), np.sqrt(2 / 602), extent=40.0)
    assert w @ ndf.pdf_h(h) == pytest.approx(1.0, rel=2e-3)
