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


def _eval_at_random_directions(mi, bsdf_dict, seed: int, n: int = 2000):
    """(wi, wo, Mitsuba's bsdf.eval (n, 3)) of a BSDF dict at n random upper-hemisphere
    direction pairs in the frame (x, y, z)."""
    import drjit as dr
    bsdf = mi.load_dict(bsdf_dict)
    rng = np.random.default_rng(seed)

    def hemi(k):
        v = rng.normal(size=(k, 3))
        v[:, 2] = np.abs(v[:, 2]) + 0.05
        return v / np.linalg.norm(v, axis=1, keepdims=True)
    wi, wo = hemi(n), hemi(n)
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(0, 0, 1)
    si.wi = mi.Vector3f(*wi.T.astype(np.float32))
    return wi, wo, _np(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*wo.T.astype(np.float32))))


@pytest.mark.parametrize("model,params", [
    ("lambert", {"kd": [0.5, 0.3, 0.2]}),
    ("beckmann", {"alpha_u": 0.05, "alpha_v": 0.3, "ks": 0.8, "kd": 0.1, "fresnel": "none"}),
    ("ggx", {"alpha_u": 0.3, "alpha_v": 0.06, "ks": 1.0, "fresnel": "conductor",
             "eta": [0.143, 0.375, 1.442], "k": [3.983, 2.386, 1.603]})])
def test_mitsuba_bsdf_is_the_sgpipe_brdf(mi, model, params):
    brdf = make_brdf(model, params)
    wi, wo, got = _eval_at_random_directions(mi, cv.bsdf_dict(brdf), 2)
    want = brdf.eval(wi, wo) * wo[:, 2:3]
    rtol = 1e-2 if model == "beckmann" else 2e-3     # Beckmann G1: Mitsuba's rational fit
    np.testing.assert_allclose(got, want, rtol=rtol, atol=1e-4 * want.max())


def test_mitsuba_roughconductor_is_the_gltf_brdf_up_to_the_smith_term(mi):
    """validation.gltf's white metal: Mitsuba's BSDF × G2_correlated / (G1 G1) = sgpipe's
    gltf_pbr at random directions: the height-correlated term is the mapping's one
    difference."""
    from sgpipe.brdf.shadowing import smith_g1_ggx, smith_g2_ggx_correlated
    from sgpipe.config.sections.fit import MaterialSpec
    from validation.gltf import gltf_bsdf_dict
    params = {"base_color": [1.0, 1.0, 1.0], "metallic": 1.0, "roughness": 0.55,
              "anisotropy": 0.0}
    brdf = make_brdf("gltf_pbr", params)
    spec = MaterialSpec(name="m", model="gltf_pbr", params=params)
    wi, wo, got = _eval_at_random_directions(mi, gltf_bsdf_dict(spec, None), 4)
    a = 0.55 ** 2
    ratio = smith_g2_ggx_correlated(wi, wo, a, a) / (smith_g1_ggx(wi, a, a)
                                                      * smith_g1_ggx(wo, a, a))
    want = brdf.eval(wi, wo) * wo[:, 2:3]
    np.testing.assert_allclose(got * ratio[:, None], want, rtol=2e-3, atol=1e-4 * want.max())
    assert np.abs(got - want).max() > 1e-3 * want.max()      # the term is not nothing


def test_tiny_scene_both_renderers_agree(mi):
    """The whole path on a 32² ball-on-floor scene (studio map, point light, Beckmann over a
    diffuse layer): whole-frame display PSNR ≥ 33 dB at 128 / 512 spp (noise-limited)."""
    from validation.run import run_scene, scene_paths, sgpipe_has_pixel_filter
    mode = "filter" if sgpipe_has_pixel_filter() else "centre"
    r = run_scene(scene_paths(["ball_on_floor_shadows"])[0], mode=mode, spp_sgpipe=128,
                  spp_mitsuba=512, size=32, log=lambda *_: None)
    assert r.metrics["display_psnr_db"] >= 33.0
    assert r.noise_floor_db >= 33.0



# --- textures and normal maps (validation.textures) ------------------------------------------

_ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def _floor_scene(mi, bsdf: dict, uv_repeat=(1.0, 1.0)):
    """data_samples/floor.obj (3 × 3, uv tangent +X) as validation.mitsuba_scene builds meshes."""
    from sgpipe.config.sections.scene import ObjectSpec
    from sgpipe.io.mesh import load_object
    from validation.mitsuba_scene import _bitmaps, _mesh
    spec = ObjectSpec(name="floor", mesh=str(_ROOT / "data_samples/floor.obj"), material="m",
                      scale=0.5, uv_repeat=uv_repeat)
    m = _mesh(mi, spec, load_object(spec), mi.load_dict(_bitmaps(mi, bsdf)))
    return mi.load_dict({"type": "scene", "floor": m})


def _hits(mi, scene, n, seed):
    """Surface interactions of n rays straight down onto the floor at random points."""
    xz = np.random.default_rng(seed).uniform(-1.45, 1.45, (n, 2))
    o = np.column_stack([xz[:, 0], np.full(n, 2.0), xz[:, 1]]).astype(np.float32)
    si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*o.T), mi.Vector3f(0, -1, 0)))
    si.wi = si.to_local(mi.Vector3f(0, 1, 0))          # towards the viewer above
    return si


def test_bitmap_texture_is_the_replica_at_mesh_uvs(mi):
    """Mitsuba's bitmap (raw, bilinear, repeat) at the mesh's uv × uv_repeat is
    validation.textures' replica, so reversed rows give sgpipe's lookup."""
    from sgpipe.reference import _sampling_jit as jit
    from validation import textures as tx
    img = np.random.default_rng(7).random((5, 7, 3))
    tex = tx.bitmap_dict(tx.bitmap_for_mitsuba(img))
    scene = _floor_scene(mi, {"type": "diffuse", "reflectance": tex}, uv_repeat=(2.0, 3.0))
    si = _hits(mi, scene, 400, 8)
    uv = np.stack([np.asarray(si.uv.x, np.float64), np.asarray(si.uv.y, np.float64)], -1)
    p = _np(si.p)
    np.testing.assert_allclose(uv, np.column_stack([(p[:, 0] + 1.5) / 3 * 2,
                                                    (1.5 - p[:, 2]) / 3 * 3]), atol=2e-5)
    got = _np(si.bsdf().eval_diffuse_reflectance(si))
    np.testing.assert_allclose(got, jit.tex_bilinear(img, uv), atol=2e-4)


def test_mesh_shading_tangent_is_the_triangles_dp_du(mi):
    """Mitsuba's mesh sh_frame.s is its triangle's ∂p/∂u made ⟂ the interpolated normal."""
    from sgpipe.config.sections.scene import ObjectSpec
    from sgpipe.io.mesh import load_object
    from validation.mitsuba_scene import _mesh
    from validation.textures import triangle_dp_du
    spec = ObjectSpec(name="s", mesh=str(_ROOT / "data_samples/sphere.obj"), material="m")
    g = load_object(spec)
    scene = mi.load_dict({"type": "scene",
                          "s": _mesh(mi, spec, g, mi.load_dict({"type": "diffuse"}))})
    d = np.random.default_rng(9).normal(size=(400, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = d[np.abs(d[:, 1]) < 0.95]
    ray = mi.Ray3f(mi.Point3f(*(3 * d).T.astype(np.float32)),
                   mi.Vector3f(*(-d).T.astype(np.float32)))
    si = scene.ray_intersect(ray)
    n = _np(si.sh_frame.n)
    t = triangle_dp_du(g.positions, g.faces, g.uvs)[np.asarray(si.prim_index)]
    t -= np.sum(t * n, 1, keepdims=True) * n
    np.testing.assert_allclose(_np(si.sh_frame.s), t / np.linalg.norm(t, axis=1, keepdims=True),
                               atol=2e-4)


def test_normalmap_normal_is_sgpipes_and_mitsubas_defaults_are_not(mi):
    """Lambert under the mapped `normalmap`: ρ·cos = kd/π · max(0, n'·ω) with n' sgpipe's
    mapped normal (frame t = +X on the floor); Mitsuba's default shadowing term lowers it."""
    from sgpipe.reference import _sampling_jit as jit
    from sgpipe.render.setup import read_texture
    from validation import textures as tx
    nm = np.asarray(read_texture(_ROOT / "data_samples/normal_map.png", "nm"), np.float64)
    lam = cv.bsdf_dict(make_brdf("lambert", {"kd": 0.5}))
    d = tx.normalmap_bsdf_dict(lam, nm)
    scene = _floor_scene(mi, d)                  # held: si.bsdf() points into it
    si = _hits(mi, scene, 600, 10)
    uv = np.stack([np.asarray(si.uv.x, np.float64), np.asarray(si.uv.y, np.float64)], -1)
    n = np.tile([0.0, 1.0, 0.0], (len(uv), 1))
    want_n = tx.mapped_normals(jit.tex_bilinear(nm, uv), np.tile([1.0, 0, 0], (len(uv), 1)), n)
    w = np.array([0.9, 0.3, 0.1]) / np.linalg.norm([0.9, 0.3, 0.1])      # a low light
    w_mi = mi.Vector3f(*[np.full(len(uv), c, np.float32) for c in w])
    want = 0.5 / np.pi * np.maximum(want_n @ w, 0.0)
    got = _np(si.bsdf().eval(mi.BSDFContext(), si, si.to_local(w_mi)))[:, 0]
    np.testing.assert_allclose(got, want, atol=2e-5)
    d["bsdf"].pop("flip_invalid_normals"), d["bsdf"].pop("use_shadowing_function")
    scene = _floor_scene(mi, d)
    si = _hits(mi, scene, 600, 10)
    got = _np(si.bsdf().eval(mi.BSDFContext(), si, si.to_local(w_mi)))[:, 0]
    assert np.abs(got - want).max() > 0.02 * want.max()


@pytest.mark.parametrize("textured", [False, True])
def test_normal_mapped_floor_renders_identically(mi, tmp_path, textured):
    """Through pixel centres under a point light (no environment), the bump-mapped floor is
    deterministic in both renderers: every pixel agrees to 10⁻⁴ (uv, tangent frame, decoding,
    the light); `textured`: GGX over Lambert with the generated kd / ks textures, tiled 2×."""
    import yaml
    from validation import assets
    from validation.run import run_scene
    src = _ROOT / "validation/scenes/normalmap_bumps_head_on.yaml"
    cfg = yaml.safe_load(src.read_text())
    obj = cfg["scene"]["objects"][0]
    obj["mesh"] = str(_ROOT / "data_samples/floor.obj")
    obj["normal_map"] = str(_ROOT / "data_samples/normal_map.png")
    cfg["fit"]["materials"][0]["model"] = "lambert"
    cfg["fit"]["materials"][0]["params"] = {"kd": [0.5, 0.4, 0.3]}
    if textured:
        obj["uv_repeat"] = [2, 2]
        cfg["fit"]["materials"][0]["model"] = "ggx"
        cfg["fit"]["materials"][0]["params"] = {"alpha": 0.2, "ks": 0.5, "kd": [0.5, 0.4, 0.3],
                                                "fresnel": "none"}
        cfg["render"]["material_textures"] = [{
            "material": "glossy", "kd_map": str(assets.ensure("kd_texture_8.exr", tmp_path)),
            "ks_map": str(assets.ensure("ks_texture_6.exr", tmp_path))}]
    cfg.pop("envmap")
    path = tmp_path / "nm.yaml"
    path.write_text(yaml.safe_dump(cfg))
    r = run_scene(path, mode="centre", spp_sgpipe=1, spp_mitsuba=2, size=24,
                  log=lambda *_: None)
    np.testing.assert_allclose(r.images["sgpipe"], r.images["mitsuba"], rtol=1e-4, atol=1e-6)
