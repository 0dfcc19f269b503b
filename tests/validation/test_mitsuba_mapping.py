"""The sgpipe → Mitsuba convention mappings of validation.conventions, without Mitsuba: each
mapped quantity is checked against sgpipe's own implementation of the convention."""

import math

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.core.maps import latlong_dir, latlong_solid_angles
from sgpipe.core.sphere import tangent_frame
from sgpipe.reference import EnvSampler
from sgpipe.scene.camera import Camera
from validation import conventions as cv

CAMERAS = [Camera(eye=(2.4, 1.9, 3.3), target=(0.0, 0.42, 0.0), fov_deg=34, width=48,
                  height=32),
           Camera(eye=(0.3, -1.0, -2.0), target=(0.1, 0.2, 0.5), up=(0.3, 1.0, 0.2),
                  fov_deg=70, width=20, height=36)]


@pytest.mark.parametrize("cam", CAMERAS)
def test_mitsuba_sensor_gives_sgpipe_primary_rays(cam):
    """Mitsuba's perspective rule on the mapped sensor reproduces sgpipe's rays at pixel
    centres and at sub-pixel positions (non-square image, tilted up vector)."""
    p = cv.sensor_params(cam)
    _, d = cam.rays()
    got = cv.mitsuba_ray_directions(p, cv.pixel_centres(cam.width, cam.height))
    np.testing.assert_allclose(got, d, atol=2e-6)
    _, d2 = cam.rays(offset=(0.1, 0.8))
    xy = cv.pixel_centres(cam.width, cam.height) + [(0.1 - 0.5) / cam.width,
                                                    (0.8 - 0.5) / cam.height]
    np.testing.assert_allclose(cv.mitsuba_ray_directions(p, xy), d2, atol=2e-6)
    # the test can fail: Mitsuba's default horizontal fov axis gives other rays
    wrong = dict(p, fov_axis="x")
    assert np.abs(cv.mitsuba_ray_directions(wrong, cv.pixel_centres(cam.width, cam.height))
                  - d).max() > 1e-2


def test_look_at_is_mitsubas_camera_frame():
    """look_at's columns: +X is the image's left (−right), +Y up, +Z forward; a film x right
    of centre looks right."""
    cam = Camera(eye=(0, 0, 5), target=(0, 0, 0), width=4, height=4)
    m = cv.look_at_matrix(cam.eye, cam.target, cam.up)
    right, up, fwd = cam.basis()
    np.testing.assert_allclose(m[:3, 0], -right)
    np.testing.assert_allclose(m[:3, 1], up)
    np.testing.assert_allclose(m[:3, 2], fwd)
    np.testing.assert_allclose(m[:3, 3], cam.eye)
    d = cv.mitsuba_ray_directions(cv.sensor_params(cam), np.array([[0.9, 0.2]]))[0]
    assert d @ right > 0 and d @ up > 0


def test_envmap_directions_agree_with_sgpipe_latlong():
    """Mitsuba's (u, v) of sgpipe's texel-centre directions is the texel's (u, v)
    (ENVMAP_TO_WORLD = identity)."""
    np.testing.assert_array_equal(cv.ENVMAP_TO_WORLD, np.eye(4))
    rng = np.random.default_rng(1)
    u, v = rng.random(500), rng.uniform(0.01, 0.99, 500)
    gu, gv = cv.mitsuba_envmap_uv(latlong_dir(u, v))
    np.testing.assert_allclose(gu, u, atol=1e-9)
    np.testing.assert_allclose(gv, v, atol=1e-9)


def test_sgpipe_envmap_eval_is_the_references_lookup():
    rng = np.random.default_rng(2)
    env = rng.random((16, 32, 3))
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rad, _ = EnvSampler(env).lookup(d)
    np.testing.assert_array_equal(cv.sgpipe_envmap_eval(env, d), rad)


def test_resampled_envmap_reproduces_the_piecewise_constant_map():
    """Mitsuba's bilinear, row-vertex-centred lookup of envmap_for_mitsuba(L, k) equals
    sgpipe's texel lookup away from texel edges, and its sphere integral matches Σ L Ω to
    the 1/(2k)-texel row offset."""
    rng = np.random.default_rng(3)
    h, w, k = 8, 16, 8
    env = rng.random((h, w, 3)) + 0.1
    big = cv.envmap_for_mitsuba(env, k)
    assert big.shape == (k * h, k * w, 3)
    # directions at least 2.5 resampled texels from every texel edge: bilinear weights there
    # only mix copies of the same texel (rows: hat means over ±1 row, then interpolation)
    u = (rng.integers(0, w, 3000) + rng.uniform(2.5 / k, 1 - 2.5 / k, 3000)) / w
    v = (rng.integers(0, h, 3000) + rng.uniform(2.5 / k, 1 - 2.5 / k, 3000)) / h
    d = latlong_dir(u, v)
    np.testing.assert_allclose(cv.mitsuba_envmap_eval(big, d), cv.sgpipe_envmap_eval(env, d),
                               rtol=1e-6)
    # the whole-sphere integral, by midpoint quadrature in (u, cos θ)
    n = 512
    uu, cc = np.meshgrid((np.arange(2 * n) + 0.5) / (2 * n), 1 - 2 * (np.arange(n) + 0.5) / n)
    vv = np.arccos(cc) / np.pi
    q = cv.mitsuba_envmap_eval(big, latlong_dir(uu, vv)).mean((0, 1)) * 4 * np.pi
    exact = (env * latlong_solid_angles(h, w)[..., None]).sum((0, 1))
    np.testing.assert_allclose(q, exact, rtol=1.0 / (2 * k * h))
    # the test can fail: Mitsuba's lookup of the original map is off by up to half a texel
    assert np.abs(cv.mitsuba_envmap_eval(env.astype(np.float32), d)
                  - cv.sgpipe_envmap_eval(env, d)).max() > 0.05


def test_sphere_to_world_gives_sgpipe_tangent():
    """Mitsuba's sphere ∂p/∂u under sphere_to_world is sgpipe's azimuthal tangent n × ŷ."""
    rng = np.random.default_rng(4)
    n = rng.normal(size=(500, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n = n[np.abs(n[:, 1]) < 0.99]
    c, r = np.array([0.3, 0.5, -1.0]), 0.7
    m = cv.sphere_to_world(c, r)
    np.testing.assert_allclose(m[:3, :3] @ [0, 0, 1], [0, -r, 0], atol=1e-12)
    t_sg, _ = tangent_frame(n)
    np.testing.assert_allclose(cv.mitsuba_sphere_tangent(m, c + r * n), t_sg, atol=1e-9)
    # unturned, Mitsuba's tangent is another vector
    plain = m @ np.linalg.inv(cv.rotation_x(90.0))
    assert np.abs(cv.mitsuba_sphere_tangent(plain, c + r * n) - t_sg).max() > 0.5


# --- materials: the mapped Mitsuba BSDF, evaluated with Mitsuba's documented formulas --------
def _mitsuba_g1(v, au, av, dist):
    """Mitsuba 3's MicrofacetDistribution::smith_g1 (Beckmann: its rational approximation)."""
    t2 = (au ** 2 * v[..., 0] ** 2 + av ** 2 * v[..., 1] ** 2) / v[..., 2] ** 2
    if dist == "beckmann":
        a = 1 / np.sqrt(t2)
        return np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a)
                        / (1 + 2.276 * a + 2.577 * a * a))
    return 2 / (1 + np.sqrt(1 + t2))


def _mitsuba_d(m, au, av, dist):
    c2 = m[..., 2] ** 2
    e = (m[..., 0] ** 2 / au ** 2 + m[..., 1] ** 2 / av ** 2) / c2
    if dist == "beckmann":
        return np.exp(-e) / (np.pi * au * av * c2 * c2)
    return 1 / (np.pi * au * av * c2 * c2 * (1 + e) ** 2)


def _fr_conductor(c, eta, k):
    """Unpolarised Fresnel of η + ik (the textbook complex-index form, Mitsuba's fresnel_conductor)."""
    n = np.asarray(eta, complex) + 1j * np.asarray(k, float)
    c = c[..., None]
    s2 = 1 - c * c
    ct = np.sqrt(1 - s2 / (n * n))
    rs = (c - n * ct) / (c + n * ct)
    rp = (n * c - ct) / (n * c + ct)
    return 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)


def _eval_mitsuba_dict(d, wi, wo):
    """f (no cosine) of a mapped BSDF dict from Mitsuba's documented component formulas."""
    if d["type"] == "twosided":
        return _eval_mitsuba_dict(d["bsdf"], wi, wo)
    if d["type"] == "diffuse":
        return np.broadcast_to(np.asarray(d["reflectance"]["value"]) / np.pi, wi.shape)
    if d["type"] == "blendbsdf":
        w = d["weight"]
        return ((1 - w) * _eval_mitsuba_dict(d["bsdf_0"], wi, wo)
                + w * _eval_mitsuba_dict(d["bsdf_1"], wi, wo))
    assert d["type"] == "roughconductor"
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    au, av, dist = d["alpha_u"], d["alpha_v"], d["distribution"]
    D, G = _mitsuba_d(h, au, av, dist), _mitsuba_g1(wi, au, av, dist) * _mitsuba_g1(wo, au, av,
                                                                                   dist)
    if d.get("material") == "none":
        F = np.ones(wi.shape)
    else:
        F = _fr_conductor(np.sum(wi * h, -1), d["eta"]["value"], d["k"]["value"])
    ks = np.asarray(d["specular_reflectance"]["value"])
    return ks * F * (D * G / (4 * wi[..., 2] * wo[..., 2]))[..., None]


MATERIALS = [
    ("lambert", {"kd": [0.5, 0.3, 0.2]}),
    ("beckmann", {"alpha": 0.1, "ks": 1.0, "fresnel": "none"}),
    ("ggx", {"alpha": 0.3, "ks": 0.6, "kd": [0.4, 0.04, 0.03], "fresnel": "none"}),
    ("beckmann", {"alpha_u": 0.05, "alpha_v": 0.3, "ks": 0.8, "fresnel": "none"}),
    ("ggx", {"alpha_u": 0.3, "alpha_v": 0.06, "ks": 1.0, "fresnel": "conductor",
             "eta": [0.143, 0.375, 1.442], "k": [3.983, 2.386, 1.603]}),
]


@pytest.mark.parametrize("model,params", MATERIALS)
def test_mapped_bsdf_evaluates_to_the_sgpipe_brdf(model, params):
    brdf = make_brdf(model, params)
    d = cv.bsdf_dict(brdf)
    rng = np.random.default_rng(5)

    def hemi(n):
        v = rng.normal(size=(n, 3))
        v[:, 2] = np.abs(v[:, 2]) + 0.05
        return v / np.linalg.norm(v, axis=1, keepdims=True)
    wi, wo = hemi(4000), hemi(4000)
    want = brdf.eval(wi, wo)
    got = _eval_mitsuba_dict(d, wi, wo)
    # Mitsuba's Beckmann G1 is a rational fit within 0.35 % per factor
    rtol = 8e-3 if "beckmann" in model else 1e-6
    np.testing.assert_allclose(got, want, rtol=rtol, atol=1e-9 * want.max())


def test_blend_weights_keep_kd_and_ks():
    brdf = make_brdf("ggx", {"alpha": 0.2, "ks": 0.6, "kd": [0.4, 0.1, 0.0],
                             "fresnel": "none"})
    b = cv.bsdf_dict(brdf)["bsdf"]
    w = b["weight"]
    np.testing.assert_allclose(np.multiply(1 - w, b["bsdf_0"]["reflectance"]["value"]),
                               [0.4, 0.1, 0.0])
    np.testing.assert_allclose(np.multiply(w, b["bsdf_1"]["specular_reflectance"]["value"]),
                               [0.6] * 3)


@pytest.mark.parametrize("model,params", [
    ("ward", {"alpha": 0.1}), ("cook_torrance", {"m": 0.2}),
    ("ggx", {"alpha": 0.1}),                               # Schlick Fresnel by default
    ("beckmann", {"alpha": 0.1, "fresnel": "dielectric", "eta": 1.5})])
def test_unmappable_materials_are_refused(model, params):
    with pytest.raises(cv.Unmappable):
        cv.bsdf_dict(make_brdf(model, params))


def test_lights():
    from sgpipe.config.sections.render import LightSpec
    p = cv.emitter_dict(LightSpec(type="point", position=(1, 2, 3), intensity=(4, 5, 6)))
    assert p == {"type": "point", "position": [1.0, 2.0, 3.0],
                 "intensity": {"type": "rgb", "value": [4.0, 5.0, 6.0]}}
    d = cv.emitter_dict(LightSpec(type="directional", direction=(0, 2, 0), intensity=(1, 1, 1)))
    assert d["direction"] == [0.0, -1.0, 0.0]   # Mitsuba: the direction light travels
    assert math.isclose(d["irradiance"]["value"][0], 1.0)


def test_pixel_filters():
    from sgpipe.config.sections.render import PixelFilterSpec
    assert cv.rfilter_dict(PixelFilterSpec()) == {"type": "box"}
    assert cv.rfilter_dict(PixelFilterSpec(type="tent")) == {"type": "tent", "radius": 1.0}
    assert cv.rfilter_dict({"type": "gaussian", "stddev": 0.3}) == {"type": "gaussian",
                                                                    "stddev": 0.3}
    for bad in ({"type": "center"}, {"type": "gaussian", "stddev": 0.5, "radius": 1.0},
                {"type": "box", "radius": 1.0}):
        with pytest.raises(cv.Unmappable):
            cv.rfilter_dict(bad)


def test_sgpipe_never_imports_mitsuba():
    """Mitsuba is validation-only: no module under sgpipe/ imports it (or drjit)."""
    import re
    from pathlib import Path
    root = Path(cv.__file__).resolve().parents[1] / "sgpipe"
    pat = re.compile(r"^\s*(import|from)\s+(mitsuba|drjit)\b", re.M)
    hits = [str(p) for p in root.rglob("*.py") if pat.search(p.read_text(encoding="utf-8"))]
    assert hits == []


def test_resampled_envmap_keeps_every_rows_energy():
    """Exact in φ (row means), fine 1-D rule in θ: Mitsuba's linear-in-v reconstruction of the
    hat-averaged rows keeps the map's power to 1e-4 (nearest-row values, which shift every row
    edge towards the pole, miss it by 0.4–1.3 % here; hat means: < 1e-7)."""
    rng = np.random.default_rng(6)
    h, w, k = 16, 8, 4
    env = np.exp(3 * rng.normal(size=(h, w, 3)))          # high-contrast rows
    rows = cv.envmap_for_mitsuba(env, k).astype(np.float64).mean(1)
    hh = len(rows)
    n = 400_000
    th = (np.arange(n) + 0.5) / n * np.pi
    y = th / np.pi * (hh - 1)
    y0 = np.floor(y).astype(int)
    f = (y - y0)[:, None]
    rec = rows[y0] * (1 - f) + rows[np.minimum(y0 + 1, hh - 1)] * f
    wgt = np.sin(th) * (np.pi / n) * 2 * np.pi
    band = np.minimum((th / np.pi * h).astype(int), h - 1)
    got = np.stack([np.bincount(band, rec[:, c] * wgt, minlength=h) for c in range(3)], -1)
    te = np.arange(h + 1) * np.pi / h
    want = 2 * np.pi * env.mean(1) * (np.cos(te[:-1]) - np.cos(te[1:]))[:, None]
    np.testing.assert_allclose(got.sum(0), want.sum(0), rtol=1e-4)
