"""`reference` with the real BRDF registry (sgpipe.brdf.make_brdf specs built per worker):
furnace with the registry Lambert, MIS / BRDF-only / env-only agreement for the paper's
Ward materials and the microfacet models."""

import numpy as np
import pytest

from reference_testlib import assert_estimators_agree
from sgpipe.io import read_exr
from sgpipe.reference import render_reference_result
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject

DATA = __import__("pathlib").Path(__file__).resolve().parents[2] / "data_samples"


def test_registry_lambert_furnace_with_sphere_mesh_occluder_free():
    """White furnace through a (model, params) spec: radiance = kd within the MC error."""
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), fov_deg=32, width=16, height=16)
    kd = [0.8, 0.5, 0.25]
    res = render_reference_result([TraceObject.sphere("s", (0, 0, 0), 1.0)], cam,
                                  read_exr(DATA / "white.exr"),
                                  materials=[("lambert", {"kd": kd})], spp=32, seed=1,
                                  workers=1)
    h = res.hit
    d = res.image[h].astype(np.float64) - kd
    se = np.sqrt(np.sum(res.stderr[h].astype(np.float64) ** 2, 0)) / h.sum()
    assert np.all(np.abs(d.mean(0)) < 5 * se + 1e-6), (d.mean(0), se)


def test_texture_scales_multiply_diffuse_and_specular():
    """kd_scale / ks_scale (SVBRDF textures): a Lambert furnace with kd_scale s gives s·kd;
    a purely specular material is unchanged by kd_scale and scaled exactly by ks_scale."""
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), fov_deg=32, width=12, height=12)
    obj = [TraceObject.sphere("s", (0, 0, 0), 1.0)]
    env = read_exr(DATA / "studio.exr")
    s = np.zeros((12, 12, 3))
    s[:, :6] = 0.5
    s[:, 6:] = 0.25
    lam = render_reference_result(obj, cam, np.ones((8, 16, 3)), materials=[("lambert",
                                  {"kd": 0.8})], spp=8, seed=0, workers=1, strategy="brdf",
                                  kd_scale=s)
    np.testing.assert_allclose(lam.image[lam.hit], (0.8 * s)[lam.hit], rtol=1e-5)
    mat = [("ward", {"alpha": 0.1, "kd": 0.0, "ks": 0.7})]
    base = render_reference_result(obj, cam, env, materials=mat, spp=8, seed=0, workers=1)
    ks = render_reference_result(obj, cam, env, materials=mat, spp=8, seed=0, workers=1,
                                 kd_scale=s, ks_scale=s)
    np.testing.assert_allclose(ks.image[ks.hit], (base.image * s)[ks.hit], rtol=1e-5)


@pytest.mark.parametrize("model,params", [
    ("ward", {"alpha": 0.1, "kd": 0.2, "ks": 0.6}),
    ("ward", {"alpha_u": 0.05, "alpha_v": 0.2, "kd": 0.1, "ks": 0.8}),
    ("ggx", {"alpha": 0.2, "kd": 0.1, "ks": 0.9, "fresnel": "schlick", "f0": 0.5}),
    ("beckmann", {"alpha": 0.15, "kd": 0.3, "ks": 0.7}),
])
def test_mis_brdf_env_agree_registry(model, params):
    """Same expectation from the three estimators (pooled z-scores < 4.5)."""
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), fov_deg=30, width=14, height=14)
    env = read_exr(DATA / "studio.exr")
    objs = [TraceObject.sphere("s", (0, 0, 0), 1.0)]
    res = {s: render_reference_result(objs, cam, env, materials=[(model, params)], spp=96,
                                      seed=21, workers=1, strategy=s)
           for s in ("mis", "brdf", "env")}
    assert_estimators_agree(res)
