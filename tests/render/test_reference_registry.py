"""`reference` with the real BRDF registry (sgpipe.brdf.make_brdf specs built per worker):
furnace with the registry Lambert, MIS / BRDF-only / env-only agreement for the paper's
Ward materials and the microfacet models."""

import numpy as np
import pytest

from sgpipe.io import read_exr
from sgpipe.render.camera import Camera
from sgpipe.render.gbuffer import TraceObject
from sgpipe.render.reference import render_reference_result
from sg_testlib import assert_estimators_agree

pytest.importorskip("sgpipe.brdf")

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


def test_reference_from_config_matches_direct_call():
    """The stage's one call (config → objects, env × exposure, materials, lights, seed) equals
    the explicit call; an undefined material is BadInput naming the key."""
    from sgpipe.errors import BadInput
    from sgpipe.experiments.figures import build_config
    from sgpipe.render.reference import materials_for_scene, reference_from_config
    mats = [{"name": "w", "model": "ward", "params": {"alpha": 0.2, "kd": 0.3, "ks": 0.5}}]
    cfg = build_config(DATA / "studio.exr", mats, "w", ["reference"], size=12, spp=4, seed=5,
                       workers=1)
    cfg.render.environment_exposure = 1.0
    res = reference_from_config(cfg)
    cam = Camera.from_spec(cfg.render.camera)
    direct = render_reference_result([TraceObject.sphere("sphere", (0, 0, 0), 1.0)], cam,
                                     2.0 * read_exr(DATA / "studio.exr"),
                                     materials=[("ward", mats[0]["params"])], spp=4, seed=5,
                                     workers=1, background="black")
    np.testing.assert_array_equal(res.image, direct.image)
    cfg.scene.objects[0].material = "nope"
    with pytest.raises(BadInput, match="nope"):
        materials_for_scene(cfg)
