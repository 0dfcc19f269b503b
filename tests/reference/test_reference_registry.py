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
    h = res.coverage == 1          # pixels inside the silhouette (box filter)
    d = res.image[h].astype(np.float64) - kd
    se = np.sqrt(np.sum(res.stderr[h].astype(np.float64) ** 2, 0)) / h.sum()
    assert np.all(np.abs(d.mean(0)) < 5 * se + 1e-6), (d.mean(0), se)


def test_texture_maps_multiply_diffuse_and_specular():
    """kd / ks maps (ObjectMaps, SVBRDF): a Lambert furnace with a constant kd map s gives s·kd;
    a purely specular material is unchanged by a kd map and scaled exactly by a ks map."""
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), fov_deg=32, width=12, height=12)
    obj = [TraceObject.sphere("s", (0, 0, 0), 1.0)]
    env = read_exr(DATA / "studio.exr")
    s = np.array([0.5, 0.25, 0.75])
    tex = np.broadcast_to(s, (4, 8, 3))
    lam = render_reference_result(obj, cam, np.ones((8, 16, 3)), materials=[("lambert",
                                  {"kd": 0.8})], spp=8, seed=0, workers=1, strategy="brdf",
                                  maps=[{"kd_map": tex}])
    cov = lam.coverage[..., None]
    np.testing.assert_allclose(lam.image, cov * 0.8 * s + (1 - cov), rtol=1e-5)
    mat = [("ward", {"alpha": 0.1, "kd": 0.0, "ks": 0.7})]
    kw = dict(materials=mat, spp=8, seed=0, workers=1, background="black")
    base = render_reference_result(obj, cam, env, **kw)
    kd = render_reference_result(obj, cam, env, maps=[{"kd_map": tex}], **kw)
    ks = render_reference_result(obj, cam, env, maps=[{"ks_map": tex}], **kw)
    np.testing.assert_allclose(kd.image, base.image, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(ks.image, base.image * s, rtol=1e-5, atol=1e-7)


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
