"""Physics of the `reference` renderer: white furnace, analytic scenes with known radiance,
exact shadows (Embree meshes and analytic spheres). Tolerances come from the estimator's own
standard error (ReferenceResult.stderr) or from float round-off where the answer is noiseless.
"""

import numpy as np
import pytest

from sgpipe.reference import render_reference_result
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject, Tracer


class Lambert:
    """ρ/π with cosine-weighted sampling: the textbook BRDF whose answers are known."""

    def __init__(self, albedo):
        self.a = np.broadcast_to(np.asarray(albedo, float), (3,)).copy()

    def eval(self, o, i):
        return np.where(((o[:, 2] > 0) & (i[:, 2] > 0))[:, None], self.a / np.pi, 0.0)

    def pdf(self, o, i):
        return np.maximum(i[:, 2], 0.0) / np.pi

    def sample(self, o, u1, u2):
        r, phi = np.sqrt(u1), 2 * np.pi * u2
        i = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0, 1 - u1))], -1)
        return i, i[:, 2] / np.pi


def _quad(name, half, y=0.0, center=(0.0, 0.0)):
    cx, cz = center
    v = np.array([[cx - half, y, cz - half], [cx + half, y, cz - half],
                  [cx + half, y, cz + half], [cx - half, y, cz + half]])
    return TraceObject.mesh(name, v, [[0, 2, 1], [0, 3, 2]])


def _within(img, want, err, sel, z=5.0):
    """Pooled check: |mean(img − want)| ≤ z · (pooled standard error) over selected pixels."""
    d = (img[sel] - want[sel]).astype(np.float64)
    se = np.sqrt(np.sum(err[sel].astype(np.float64) ** 2, axis=0)) / sel.sum()
    assert np.all(np.abs(d.mean(axis=0)) <= z * se + 1e-6), (d.mean(axis=0), se)
    # and no single pixel is wildly off (7σ with a floor for float32 round-off)
    zpix = np.abs(d) / (err[sel] + 1e-5)
    assert zpix.max() < 7.0, zpix.max()


@pytest.mark.parametrize("strategy", ["mis", "brdf", "env"])
def test_white_furnace(strategy):
    """Constant white environment, Lambert sphere of albedo ρ, box pixel filter: a pixel is
    c·ρ + (1 − c)·1 with c its fraction of samples that hit the sphere (`coverage`)."""
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), fov_deg=32, width=20, height=20)
    rho = np.array([0.8, 0.5, 0.25])
    env = np.ones((16, 32, 3))
    res = render_reference_result([TraceObject.sphere("s", (0, 0, 0), 1.0)], cam, env,
                                  materials=[Lambert(rho)], spp=32, seed=3, workers=1,
                                  strategy=strategy)
    hit = res.hit
    assert hit.sum() > 150
    c = res.coverage[..., None].astype(np.float64)
    assert 0 < np.sum((c > 0) & (c < 1)) < 0.3 * c.size    # the silhouette's partial pixels
    want = c * rho + (1 - c) * 1.0
    _within(res.image, want, res.stderr, res.coverage == 1)
    # partly covered pixels pooled (a pixel's own stderr is unreliable with few hit samples)
    part = (res.coverage > 0) & (res.coverage < 1)
    d = (res.image[part] - want[part]).astype(np.float64)
    se = np.sqrt(np.sum(res.stderr[part].astype(np.float64) ** 2, axis=0)) / part.sum()
    assert np.all(np.abs(d.mean(axis=0)) <= 5 * se + 1e-6), (d.mean(axis=0), se)
    assert np.all(res.image[res.coverage == 0] == 1.0)  # background shows the environment
    if strategy == "brdf":  # cosine sampling × constant integrand: zero variance
        assert np.abs(res.image - want).max() < 1e-5


def test_furnace_stderr_is_honest():
    """The reported standard error matches the spread between independent seeds."""
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), fov_deg=32, width=16, height=16)
    env = np.ones((16, 32, 3))
    obj = [TraceObject.sphere("s", (0, 0, 0), 1.0)]
    a = render_reference_result(obj, cam, env, materials=[Lambert(0.7)], spp=16, seed=1,
                                workers=1, strategy="env")
    b = render_reference_result(obj, cam, env, materials=[Lambert(0.7)], spp=16, seed=2,
                                workers=1, strategy="env")
    h = (a.coverage == 1) & (b.coverage == 1)   # the silhouette's coverage is stratified
    spread = np.var((a.image - b.image)[h][:, 0]) / 2          # ≈ mean stderr²
    claimed = np.mean(a.stderr[h][:, 0] ** 2)
    assert 0.6 < spread / claimed < 1.6, (spread, claimed)


def _plane_scene_pixels(objs, cam):
    o, d = cam.rays()
    gb = Tracer(objs).trace(o, d)
    return gb


def test_directional_and_point_lights_with_sphere_shadow():
    """Lambert plane, black environment, pixel-centre rays: L = ρ/π (E cos θ + I cos θ'/r²)·V,
    exact (no noise);
    V from the test's own ray–sphere test, pixels within 1e-3 of the shadow edge skipped."""
    cam = Camera(eye=(0, 3, 3), target=(0, 0, 0), fov_deg=60, width=32, height=28)
    rho = np.array([0.9, 0.6, 0.3])
    c, r = np.array([0.1, 0.5, -0.3]), 0.4
    objs = [_quad("floor", 2.0), TraceObject.sphere("ball", c, r)]
    ldir = np.array([1.0, 1.2, 0.3]) / np.linalg.norm([1.0, 1.2, 0.3])
    E = np.array([2.0, 1.0, 0.5])
    lpos, I = np.array([-1.0, 1.5, 0.8]), np.array([0.5, 0.7, 1.1])
    lights = [{"type": "directional", "direction": ldir, "irradiance": E},
              {"type": "point", "position": lpos, "intensity": I}]
    res = render_reference_result(objs, cam, None, materials=[Lambert(rho), Lambert(rho)],
                                  lights=lights, spp=1, seed=0, workers=1, background="black",
                                  pixel_filter="center")
    gb = _plane_scene_pixels(objs, cam)
    floor = gb.hit & (gb.object_id == 0)
    p = gb.position[floor].astype(np.float64)

    def ray_sphere(orig, dirs, tmax):
        oc = orig - c
        b = np.einsum("ij,ij->i", oc, dirs)
        q = np.einsum("ij,ij->i", oc, oc) - r * r
        disc = b * b - q
        t = -b - np.sqrt(np.maximum(disc, 0))
        miss_margin = np.sqrt(np.maximum(q - b * b + r * r, 0)) - r  # ray–centre distance − r
        return (disc > 0) & (t > 0) & (t < tmax), np.abs(miss_margin)

    sd, md = ray_sphere(p, np.broadcast_to(ldir, p.shape), np.inf)
    dp = lpos - p
    dist = np.linalg.norm(dp, axis=1)
    sp, mp = ray_sphere(p, dp / dist[:, None], dist)
    want = rho / np.pi * (E * ldir[1] * ~sd[:, None] + I * (dp[:, 1] / dist / dist ** 2)[:, None]
                          * ~sp[:, None])
    clear = (md > 1e-3) & (mp > 1e-3)
    assert sd.sum() > 5 and sp.sum() > 5 and clear.sum() > 0.9 * len(p)
    got = res.image[floor][clear]
    np.testing.assert_allclose(got, want[clear], rtol=1e-4, atol=1e-6)
    assert np.all(res.stderr[floor] == 0)


def _cap_occlusion(p, c, r):
    """Projected solid angle of a sphere entirely above a surface with normal +Y: π sin²α cos β."""
    d = c - p
    dist = np.linalg.norm(d, axis=1)
    return np.pi * (r / dist) ** 2 * (d[:, 1] / dist)


def _polygon_occlusion(p, verts):
    """Lambert's contour formula: projected solid angle (normal +Y) of a polygon above p."""
    a = verts[None, :, :] - p[:, None, :]
    a /= np.linalg.norm(a, axis=2, keepdims=True)
    b = np.roll(a, -1, axis=1)
    cr = np.cross(a, b)
    gamma = np.arccos(np.clip(np.sum(a * b, axis=2), -1, 1))
    nc = cr / np.linalg.norm(cr, axis=2, keepdims=True)
    return np.abs(0.5 * np.sum(gamma * nc[:, :, 1], axis=1))


@pytest.mark.parametrize("occluder", ["sphere", "mesh"])
def test_uniform_sky_with_known_occluder(occluder):
    """Lambert floor under a uniform sky L with an occluder overhead: L_o = ρ L (1 − Φ/π),
    Φ the occluder's projected solid angle (sphere cap: π sin²α cos β; polygon: Lambert's
    contour integral). Exercises analytic-sphere and Embree shadow rays and MIS together."""
    cam = Camera(eye=(0, 3.5, 2.0), target=(0, 0, 0), fov_deg=50, width=24, height=24)
    rho, L = 0.75, 2.0
    if occluder == "sphere":
        c, r = np.array([0.2, 1.0, 0.1]), 0.45
        occ = TraceObject.sphere("ball", c, r)
    else:
        sq = np.array([[-0.5, 0.8, -0.4], [0.6, 0.8, -0.4], [0.6, 0.8, 0.5], [-0.5, 0.8, 0.5]])
        occ = TraceObject.mesh("card", sq, [[0, 1, 2], [0, 2, 3]])
    objs = [_quad("floor", 1.5), occ]
    env = np.full((32, 64, 3), L)
    res = render_reference_result(objs, cam, env, materials=[Lambert(rho), Lambert(0.5)],
                                  spp=48, seed=11, workers=1, pixel_filter="center")
    gb = _plane_scene_pixels(objs, cam)
    floor = gb.hit & (gb.object_id == 0)
    p = gb.position[floor].astype(np.float64)
    phi = _cap_occlusion(p, c, r) if occluder == "sphere" else _polygon_occlusion(p, sq)
    want = np.zeros(res.image.shape)
    want[floor] = (rho * L * (1 - phi / np.pi))[:, None]
    assert phi.max() > 0.3  # the occluder matters
    _within(res.image, want, res.stderr, floor)
