"""χ² tests of every model's importance sampler against its own pdf, and pdf/eval consistency."""

from __future__ import annotations

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.brdf.ndf import TabulatedNDF
from .chi2util import chi2_test

CASES = [
    ("lambert", {"kd": 0.7}),
    ("blinn_phong", {"exponent": 40, "kd": 0.3, "ks": 0.6}),
    ("cook_torrance", {"m": 0.3, "kd": 0.2}),
    ("ward", {"alpha": 0.1}),
    ("ward", {"alpha_u": 0.05, "alpha_v": 0.3}),
    ("ashikhmin_shirley", {"nu": 50, "nv": 500, "rd": 0.3}),
    ("beckmann", {"alpha_u": 0.2, "alpha_v": 0.5}),
    ("ggx", {"alpha": 0.15, "kd": 0.1}),
    ("ggx", {"alpha_u": 0.1, "alpha_v": 0.4, "fresnel": "conductor"}),
    ("gltf_pbr", {"base_color": [0.7, 0.5, 0.3], "metallic": 0.3, "roughness": 0.45}),
]
O = np.array([np.sin(0.7) * np.cos(0.5), np.sin(0.7) * np.sin(0.5), np.cos(0.7)])
P_MIN = 1e-3   # one failure in 1000 by chance per test: the suite stays deterministic (seeded)


@pytest.mark.parametrize("model,params", CASES, ids=[f"{m}-{i}" for i, (m, _) in enumerate(CASES)])
def test_sampler_matches_pdf(model, params):
    brdf = make_brdf(model, params)
    width = 0.2 if brdf.has_specular else 1.0     # innermost cells resolve the sharpest lobe
    axis = O * np.array([-1.0, -1.0, 1.0]) if brdf.has_specular else np.array([0, 0, 1.0])
    p, stat, dof, mass = chi2_test(lambda u1, u2: brdf.sample(O, u1, u2),
                                   lambda d: brdf.pdf(O, d), axis, width)
    assert mass <= 1.0 + 1e-3
    assert p > P_MIN, f"chi2 {stat:.1f} dof {dof} p {p:.2e}"


def test_chi2_detects_a_wrong_pdf():
    """The test can fail: a sampler checked against a slightly wrong pdf is rejected."""
    brdf = make_brdf("ggx", {"alpha": 0.2})
    axis = O * np.array([-1.0, -1.0, 1.0])
    p, *_ = chi2_test(lambda u1, u2: brdf.sample(O, u1, u2),
                      lambda d: make_brdf("ggx", {"alpha": 0.22}).pdf(O, d), axis, 0.4)
    assert p < 1e-6


def test_tabulated_ndf_sampler():
    theta = np.linspace(0.0, np.pi / 2, 90)
    ndf = TabulatedNDF(theta, np.exp(-np.tan(theta) ** 2 / 0.04))
    from sgpipe.brdf.base import BRDF
    from sgpipe.brdf.shadowing import Shadowing
    brdf = BRDF("tabulated", ks=1.0, ndf=ndf, shadowing=Shadowing("implicit"))
    p, *_ = chi2_test(lambda u1, u2: brdf.sample(O, u1, u2), lambda d: brdf.pdf(O, d),
                      O * np.array([-1.0, -1.0, 1.0]), 0.4)
    assert p > P_MIN


@pytest.mark.parametrize("model,params", CASES[1:], ids=[f"{m}-{i}" for i, (m, _) in
                                                         enumerate(CASES[1:])])
def test_specular_lobe_sampler_and_pdf_agree(model, params):
    """sample(lobe='specular') returns exactly pdf(lobe='specular') at its samples."""
    brdf = make_brdf(model, params)
    rng = np.random.default_rng(3)
    u = rng.random((2, 2000))
    i, pdf = brdf.sample(O, u[0], u[1], lobe="specular")
    ok = pdf > 0
    np.testing.assert_allclose(pdf[ok], brdf.pdf(O, i[ok], lobe="specular"), rtol=1e-9)
