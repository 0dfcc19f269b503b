"""With Mitsuba 3 installed (the [validate] extra; CI does not install it): the numpy replicas
of validation.conventions against Mitsuba itself, and a tiny scene rendered by both."""

import numpy as np
import pytest

pytest.importorskip("mitsuba")

from sgpipe.brdf import make_brdf  # noqa: E402
from sgpipe.core.sphere import tangent_frame  # noqa: E402
from sgpipe.scene.camera import Camera  # noqa: E402
from validation import conventions as cv  # noqa: E402
from validation import import_mitsuba  # noqa: E402


@pytest.fixture(scope="module")
def mi():
    try:
        return import_mitsuba()
    except (ImportError, AttributeError) as e:   # no llvm_ad_rgb here (no libLLVM)
        pytest.skip(f"Mitsuba's llvm_ad_rgb variant unavailable: {e}")


def _np(v):
    return np.stack([np.asarray(v[k], np.float64) for k in range(3)], -1)


def test_sensor_rays_are_sgpipe_rays(mi):
    cam = Camera(eye=(2.4, 1.9, 3.3), target=(0.0, 0.42, 0.0), up=(0.1, 1.0, 0.0), fov_deg=34,
                 width=24, height=16)
    p = cv.sensor_params(cam)
    sensor = mi.load_dict({"type": "perspective", "fov": p["fov"], "fov_axis": p["fov_axis"],
                           "to_world": mi.ScalarTransform4f(p["to_world"]),
                           "film": {"type": "hdrfilm", "width": 24, "height": 16}})
    xy = cv.pixel_centres(24, 16).reshape(-1, 2)
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(xy[:, 0], xy[:, 1]), mi.Point2f(0.5, 0.5))
    _, d = cam.rays()
    np.testing.assert_allclose(_np(ray.d), d.reshape(-1, 3), atol=3e-6)
    # Mitsuba starts rays on its near clip plane, on the line from the eye
    off = _np(ray.o) - np.asarray(cam.eye)
    np.testing.assert_allclose(np.cross(off, d.reshape(-1, 3)), 0.0, atol=1e-6)


def test_envmap_lookup_is_the_replica(mi):
    import drjit as dr
    rng = np.random.default_rng(0)
    data = rng.random((8, 16, 3)).astype(np.float32)
    em = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(data),
                       "to_world": mi.ScalarTransform4f(cv.ENVMAP_TO_WORLD)})
    d = rng.normal(size=(500, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    si = dr.zeros(mi.SurfaceInteraction3f, len(d))
    si.wi = mi.Vector3f(*(-d.T.astype(np.float32)))
    got = _np(em.eval(si))
    np.testing.assert_allclose(got, cv.mitsuba_envmap_eval(data, d), rtol=2e-4, atol=2e-5)


def test_sphere_shading_frame_is_sgpipes(mi):
    c, r = (0.2, 0.5, -0.3), 0.8
    scene = mi.load_dict({"type": "scene", "s": {"type": "sphere", "to_world":
                                                 mi.ScalarTransform4f(cv.sphere_to_world(c, r))}})
    rng = np.random.default_rng(1)
    n = rng.normal(size=(300, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n = n[np.abs(n[:, 1]) < 0.98]
    o = np.asarray(c) + 3 * n
    ray = mi.Ray3f(mi.Point3f(*o.T.astype(np.float32)), mi.Vector3f(*(-n.T).astype(np.float32)))
    si = scene.ray_intersect(ray)
    t, b = tangent_frame(n)
    np.testing.assert_allclose(_np(si.sh_frame.n), n, atol=1e-4)
    np.testing.assert_allclose(_np(si.sh_frame.s), t, atol=1e-4)
    np.testing.assert_allclose(_np(si.sh_frame.t), b, atol=1e-4)


@pytest.mark.parametrize("model,params", [
    ("lambert", {"kd": [0.5, 0.3, 0.2]}),
    ("beckmann", {"alpha_u": 0.05, "alpha_v": 0.3, "ks": 0.8, "kd": 0.1, "fresnel": "none"}),
    ("ggx", {"alpha_u": 0.3, "alpha_v": 0.06, "ks": 1.0, "fresnel": "conductor",
             "eta": [0.143, 0.375, 1.442], "k": [3.983, 2.386, 1.603]})])
def test_mitsuba_bsdf_is_the_sgpipe_brdf(mi, model, params):
    import drjit as dr
    brdf = make_brdf(model, params)
    bsdf = mi.load_dict(cv.bsdf_dict(brdf))
    rng = np.random.default_rng(2)

    def hemi(k):
        v = rng.normal(size=(k, 3))
        v[:, 2] = np.abs(v[:, 2]) + 0.05
        return v / np.linalg.norm(v, axis=1, keepdims=True)
    wi, wo = hemi(2000), hemi(2000)
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(0, 0, 1)
    si.wi = mi.Vector3f(*wi.T.astype(np.float32))
    got = _np(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*wo.T.astype(np.float32))))
    want = brdf.eval(wi, wo) * wo[:, 2:3]
    rtol = 1e-2 if model == "beckmann" else 2e-3     # Beckmann G1: Mitsuba's rational fit
    np.testing.assert_allclose(got, want, rtol=rtol, atol=1e-4 * want.max())


def test_tiny_scene_both_renderers_agree(mi):
    """The whole path on a 32² ball-on-floor scene (studio map, point light, Beckmann over a
    diffuse layer): whole-frame display PSNR ≥ 33 dB at 128 / 512 spp (noise-limited)."""
    from validation.run import run_scene, scene_paths, sgpipe_has_pixel_filter
    mode = "filter" if sgpipe_has_pixel_filter() else "centre"
    r = run_scene(scene_paths(["ball_on_floor_shadows"])[0], mode=mode, spp_sgpipe=128,
                  spp_mitsuba=512, size=32, log=lambda *_: None)
    assert r.metrics["display_psnr_db"] >= 33.0
    assert r.noise_floor_db >= 33.0
