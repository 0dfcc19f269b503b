"""Models against independent closed forms, reciprocity, registry and parameter validation."""

from __future__ import annotations

import numpy as np
import pytest

from sgpipe.brdf import REGISTRY, BRDFParamError, make_brdf
from sgpipe.brdf.fresnel import fresnel_conductor, fresnel_dielectric, fresnel_schlick


def _dirs(n, seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)


O, I = _dirs(500, 1), _dirs(500, 2)
H = (O + I) / np.linalg.norm(O + I, axis=1, keepdims=True)
CI, CO, CH = I[:, 2], O[:, 2], H[:, 2]


def test_registry_has_every_model():
    assert {"lambert", "blinn_phong", "cook_torrance", "ward", "ashikhmin_shirley", "beckmann",
            "ggx", "gltf_pbr", "merl"} <= set(REGISTRY)


def test_ggx_closed_form():
    a = 0.3
    b = make_brdf("ggx", {"alpha": a, "fresnel": "none"})
    d = a * a / (np.pi * (CH**2 * (a * a - 1) + 1) ** 2)
    g1 = lambda c: 2 * c / (c + np.sqrt(a * a + (1 - a * a) * c * c))  # noqa: E731
    np.testing.assert_allclose(b.eval(O, I)[:, 0], d * g1(CI) * g1(CO) / (4 * CI * CO), rtol=1e-10)


def test_ward_anisotropic_closed_form():
    au, av = 0.1, 0.3
    b = make_brdf("ward", {"alpha_u": au, "alpha_v": av, "kd": 0.2, "ks": 0.5})
    e = -((H[:, 0] / au) ** 2 + (H[:, 1] / av) ** 2) / CH**2
    ref = 0.2 / np.pi + 0.5 * np.exp(e) / (4 * np.pi * au * av * np.sqrt(CI * CO))
    np.testing.assert_allclose(b.eval(O, I)[:, 1], ref, rtol=1e-10)


def test_blinn_phong_and_cook_torrance_closed_forms():
    b = make_brdf("blinn_phong", {"exponent": 30, "ks": 0.5})
    np.testing.assert_allclose(b.eval(O, I)[:, 0], 0.5 * 32 / (8 * np.pi) * CH**30, rtol=1e-10)
    m = 0.25
    c = make_brdf("cook_torrance", {"m": m, "fresnel": "none"})           # Wang09 eq 10
    oh = np.sum(O * H, axis=1)
    s = np.minimum(1, np.minimum(2 * CH * CO / oh, 2 * CH * CI / oh))
    ref = s / (np.pi * CI * CO) * np.exp(-(np.arccos(CH) / m) ** 2)
    np.testing.assert_allclose(c.eval(O, I)[:, 0], ref, rtol=1e-10)


def test_ashikhmin_shirley_closed_form():
    nu, nv, rs, rd = 20.0, 200.0, 0.1, 0.4
    b = make_brdf("ashikhmin_shirley", {"nu": nu, "nv": nv, "rs": rs, "rd": rd})
    phi = np.arctan2(H[:, 1], H[:, 0])
    k = np.sum(O * H, axis=1)
    f = rs + (1 - rs) * (1 - k) ** 5
    spec = (np.sqrt((nu + 1) * (nv + 1)) / (8 * np.pi) * CH ** (nu * np.cos(phi) ** 2
            + nv * np.sin(phi) ** 2) / (k * np.maximum(CI, CO)) * f)
    diff = (28 * rd / (23 * np.pi) * (1 - rs) * (1 - (1 - CI / 2) ** 5) * (1 - (1 - CO / 2) ** 5))
    np.testing.assert_allclose(b.eval(O, I)[:, 0], spec + diff, rtol=1e-9)


@pytest.mark.parametrize("model,params", [
    ("blinn_phong", {"exponent": 10, "kd": 0.2}), ("cook_torrance", {"m": 0.3}),
    ("ward", {"alpha_u": 0.1, "alpha_v": 0.2}), ("beckmann", {"alpha": 0.3}),
    ("ggx", {"alpha_u": 0.2, "alpha_v": 0.5}), ("ashikhmin_shirley", {"nu": 10, "nv": 90})])
def test_reciprocity_and_factorisation(model, params):
    b = make_brdf(model, params)
    np.testing.assert_allclose(b.eval(O, I), b.eval(I, O), rtol=1e-9)
    spec = b.remaining_factor(O, I) * b.ndf(H)[:, None]              # Wang09 eq 9
    np.testing.assert_allclose(b.eval(O, I) - b.diffuse(O, I), spec, rtol=1e-12, atol=1e-12)


def test_zero_below_horizon():
    b = make_brdf("ggx", {"alpha": 0.3, "kd": 0.5})
    below = I * np.array([1, 1, -1.0])
    assert np.all(b.eval(O, below) == 0) and np.all(b.eval(below, I) == 0)


def test_fresnel_dielectric_matches_snell():
    c = np.linspace(0.01, 1.0, 50)
    eta = 1.5
    s = np.sqrt(1 - c * c) / eta
    ct = np.sqrt(1 - s * s)
    rs = ((c - eta * ct) / (c + eta * ct)) ** 2
    rp = ((eta * c - ct) / (eta * c + ct)) ** 2
    np.testing.assert_allclose(fresnel_dielectric(c, eta)[:, 0], 0.5 * (rs + rp), rtol=1e-10)
    np.testing.assert_allclose(fresnel_conductor(c, eta, 0.0)[:, 0], 0.5 * (rs + rp), rtol=1e-9)
    assert np.all(fresnel_dielectric(np.array([0.1]), 0.9) == 1.0)    # total internal reflection
    np.testing.assert_allclose(fresnel_schlick(1.0, [0.04, 0.5, 0.9]), [0.04, 0.5, 0.9])


def test_conductor_normal_incidence():
    eta, k = np.array([0.2, 0.9, 1.1]), np.array([3.9, 2.4, 2.2])
    ref = ((eta - 1) ** 2 + k * k) / ((eta + 1) ** 2 + k * k)
    np.testing.assert_allclose(fresnel_conductor(np.array([1.0]), eta, k)[0], ref, rtol=1e-10)


@pytest.mark.parametrize("model,params,bad", [
    ("ggx", {"alpha": -0.1}, "alpha"), ("ggx", {"alpha": 1.5}, "alpha"),
    ("ward", {"alpha_u": 0.1}, "alpha_v"),
    ("beckmann", {"alpha": 0.2, "roughness": 1}, "roughness"),
    ("lambert", {"kd": 1.2}, "kd"), ("cook_torrance", {"m": 0.0}, "m"),
    ("ggx", {"fresnel": "metal"}, "fresnel"), ("ggx", {"fresnel": "dielectric", "eta": -1}, "eta"),
    ("blinn_phong", {"exponent": "shiny"}, "exponent"), ("ggx", {"kd": [0.1, 0.2]}, "kd")])
def test_bad_params_name_the_parameter(model, params, bad):
    with pytest.raises(BRDFParamError) as e:
        make_brdf(model, params)
    assert e.value.param == bad


def test_unknown_model():
    with pytest.raises(KeyError, match="unknown BRDF model"):
        make_brdf("phong2000", {})


def test_microfacet_params_codes():
    mf = make_brdf("ggx", {"alpha_u": 0.1, "alpha_v": 0.2,
                           "fresnel": "conductor"}).microfacet_params()
    assert (mf["fresnel"], mf["shadowing"], mf["diffuse"]) == (2, 3, 2)
    assert mf["g_scale"] == pytest.approx(1 / (4 * 0.1 * 0.2))
    assert (mf["alpha_u"], mf["alpha_v"]) == (0.1, 0.2)
