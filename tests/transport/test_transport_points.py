"""The `transport` method's point lights (kernels/transport_shade.cl): an object with SSDF
visibility shades the environment's point set (the sun) as delta lights with the SSDF's hard
horizon, the SH light being the map minus the points (render.transport_data.transport_arrays).
Proven on the SH split itself (whole = residual + points, the points' coefficients Σ E_k Y(c_k))
and on a ball's sun shadow on a Lambert floor against the Monte Carlo reference: the 25-term
PRT alone blurs the shadow away. Local lights (render.lights) through the same SSDF horizon,
against the reference; delta lights' glossy part is the exact specular BRDF (the NDF table),
checked per pixel."""

import textwrap

import numpy as np
import pytest

from sgpipe.artifacts.render import read_gbuffer, read_image
from sgpipe.config import load_config
from sgpipe.core.sh import sh_eval
from sgpipe.metrics import compare_images, surface_mask
from sgpipe.render.transport_data import SH_COEFFS, transport_arrays
from tiny_scene import SAMPLES, write_floor  # tests/ is on sys.path

RNG = np.random.default_rng(5)


def test_light_sh_split_into_map_minus_points_and_points():
    """tp_light_sh rows: the whole map's coefficients, minus Σ_k E_k Y(c_k), and that sum,
    each turned by the environment rotation like the map."""
    from sgpipe.core.rotation import rotation_matrix
    from sgpipe.render.transport_data import rotate_sh
    light = RNG.normal(size=(SH_COEFFS, 3))
    dirs = RNG.normal(size=(3, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    energy = RNG.uniform(0.5, 4.0, size=(3, 3))
    R = rotation_matrix([0.2, 1.0, 0.3], 70.0)
    arrays = transport_arrays([None], light, R, (dirs, energy))
    L = arrays["tp_light_sh"][:, :3]
    pts = sh_eval(dirs, 4).T @ energy
    np.testing.assert_allclose(L[:SH_COEFFS], rotate_sh(light, R), atol=2e-5)
    np.testing.assert_allclose(L[2 * SH_COEFFS:], rotate_sh(pts, R), atol=2e-5)
    np.testing.assert_allclose(L[SH_COEFFS:2 * SH_COEFFS] + L[2 * SH_COEFFS:],
                               L[:SH_COEFFS], atol=2e-5)
    # the points' SH turned = the SH of the turned points (the kernel's world directions)
    np.testing.assert_allclose(L[2 * SH_COEFFS:], sh_eval(dirs @ R.T, 4).T @ energy, atol=2e-5)
    # the small lights are turned too (three points far apart: three lights)
    suns = arrays["tp_suns"].reshape(-1, 2, 4)
    assert arrays["tp_n_suns"] == 3
    got = sorted(map(tuple, np.round(suns[:, 0, :3], 5)))
    np.testing.assert_allclose(got, sorted(map(tuple, np.round(dirs @ R.T, 5))), atol=2e-5)
    # no point set: the residual is the whole map
    L0 = transport_arrays([None], light)["tp_light_sh"][:, :3]
    np.testing.assert_allclose(L0[SH_COEFFS:2 * SH_COEFFS], light, atol=1e-6)
    assert not L0[2 * SH_COEFFS:].any()


CONFIG = """
name: sunshadow
seed: 1
workers: 1
scene:
  objects:
    - {{name: ball, sphere_radius: 0.5, translate: [0, 0.5, 0], material: ball}}
    - {{name: floor, mesh: floor.obj, material: floor}}
fit:
  materials:
    - {{name: ball, {ball}}}
    - {{name: floor, model: lambert, params: {{kd: [0.5, 0.5, 0.5]}}}}
envmap: {{environment: {env}, cube_resolution: 32}}
visibility: {{trace_resolution: 32, resolution: 16, pca_terms: 8, sphere_subdivisions: 1}}
transport: {{cube_resolution: 8, sphere_subdivisions: 1, max_iterations: 5, report_vertices: 0}}
render:
  camera: {{eye: [0, 2.6, 3.2], target: [-0.3, 0.2, 0], fov_deg: 42, width: 40, height: 40}}
  methods: [transport, reference]
  spp: 64
  supersample: 2
  compare_to: null
{extra}"""
LAMBERT_BALL = "model: lambert, params: {kd: [0.3, 0.3, 0.3]}"


@pytest.mark.opencl
def test_sun_shadow_on_floor_matches_reference(tmp_path):
    """Ball on a Lambert floor under the sky-and-sun sample: the floor's display PSNR against
    the reference (exposure −2, the shadow's edge in range). With the point set in the SH
    light instead (objects without SSDF, the previous behaviour) the shadow is a blur: the
    same scene scores ≥ 6 dB lower (measured 31.6 vs 21.0 dB)."""
    from sgpipe.stages import envmap, fit, render, transport, visibility
    write_floor(tmp_path / "floor.obj", 49)
    p = tmp_path / "sun.yaml"
    p.write_text(textwrap.dedent(CONFIG.format(env=SAMPLES / "sky_sun.exr", ball=LAMBERT_BALL,
                                               extra="")))
    out = tmp_path / "out"
    scores = {}
    for split in (True, False):
        cfg = load_config(p) if split else load_config(p, ["envmap.pyramid_max_points=0"])
        for stage in (fit, envmap, visibility, transport, render):
            stage.run(cfg, out)
        gb = read_gbuffer(out / "render")
        floor = surface_mask(gb.object_id) & (gb.object_id == 1)
        ref, img = read_image(out / "render", "reference"), read_image(out / "render",
                                                                        "transport")
        scores[split] = compare_images(img, ref, exposure=-2.0,
                                       surface=floor)["surface"]["display_psnr_db"]
    assert scores[True] >= 29.0, scores
    assert scores[True] >= scores[False] + 6.0, scores


def test_merge_points_keeps_energy_and_sets_sharpness_from_spread():
    """A sun spread over texels merges into one light: energy summed, direction the
    energy-weighted mean, λ = 2/⟨ψ²⟩ (an SG of that λ has the same mean squared angle); a
    point far away stays its own (delta: the λ cap)."""
    from sgpipe.render.transport_data import MAX_POINT_LAMBDA, merge_points
    c = np.array([0.0, 0.6, 0.8])
    t = np.array([1.0, 0.0, 0.0])
    psi = np.radians(1.0)
    sun = [np.cos(psi) * c - np.sin(psi) * t, c, np.cos(psi) * c + np.sin(psi) * t]
    far = np.array([0.0, -1.0, 0.0])
    e = np.array([[1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [1.0, 1.0, 1.0], [0.5, 0.4, 0.3]])
    rec = merge_points(np.array([*sun, far]), e)
    assert rec.shape == (2, 2, 4)
    np.testing.assert_allclose(rec[0, 0, :3], c, atol=1e-6)
    np.testing.assert_allclose(rec[0, 1, :3], [4.0, 4.0, 4.0], rtol=1e-6)
    np.testing.assert_allclose(rec[0, 0, 3], 2.0 / (0.5 * psi ** 2), rtol=1e-4)
    np.testing.assert_allclose(rec[1, 0, :3], far, atol=1e-7)
    np.testing.assert_allclose(rec[1, 1, :3], e[3], rtol=1e-6)
    assert rec[1, 0, 3] == np.float32(MAX_POINT_LAMBDA)


LIGHTS = """  environment_exposure: -30
  lights:
    - {type: directional, direction: [0.6, 0.7, 0.3], intensity: [3, 3, 3]}
    - {type: point, position: [-1.5, 2.0, 1.5], intensity: [8, 6, 4], radius: 0.05}
"""


@pytest.mark.opencl
def test_local_lights_match_reference(tmp_path):
    """render.lights in `transport`: a glossy GGX ball on a Lambert floor lit only by a
    directional and a point light (the environment 2^-30 dark). Glossy: the exact specular BRDF
    at each (sharp) light; diffuse: f_d E max(0, n·l) with the SSDF horizon. Surface display
    PSNR against the reference ≥ 34 dB (measured 38.3 dB); without the lights the frame is
    black. The ball's five brightest pixels within 5 % of the reference's (measured +0.5 %;
    −12 % with the Gaussians' w·G(l), one Gaussian's peak under GGX's)."""
    from sgpipe.stages import envmap, fit, render, transport, visibility
    write_floor(tmp_path / "floor.obj", 49)
    p = tmp_path / "lights.yaml"
    ball = "model: ggx, params: {alpha: 0.25, kd: [0.2, 0.15, 0.1], ks: 0.7}"
    p.write_text(textwrap.dedent(CONFIG.format(env=SAMPLES / "sky_sun.exr", ball=ball,
                                               extra=LIGHTS)))
    out = tmp_path / "out"
    cfg = load_config(p)
    for stage in (fit, envmap, visibility, transport, render):
        stage.run(cfg, out)
    gb = read_gbuffer(out / "render")
    surf = surface_mask(gb.object_id)
    ref, img = read_image(out / "render", "reference"), read_image(out / "render", "transport")
    c = compare_images(img, ref, exposure=0.0, surface=surf)["surface"]["display_psnr_db"]
    ball_px = surf & (gb.object_id == 0)
    top = np.sort(img[ball_px].mean(-1))[-5:].mean() / np.sort(ref[ball_px].mean(-1))[-5:].mean()
    assert c >= 34.0, c
    assert 0.95 <= top <= 1.05, top


@pytest.mark.opencl
def test_delta_light_glossy_is_the_exact_brdf(tmp_path):
    """A pure-specular GGX ball under one directional light (the environment 2^-30 dark): at
    every ball pixel lit from above its horizon, `transport` is E f_s(o, l) (n·l), the exact
    BRDF (shading.h via the NDF table, the SSDF horizon 1 there): p95 relative error ≤ 0.1 %
    (measured 0.001 %). The Gaussians' w·G(l) (TP_GAUSSIAN_POINTS) keep the lobe's integral
    but not its value at one direction: median error 28 %."""
    from sgpipe.render.setup import material_brdf
    from sgpipe.stages import envmap, fit, render, transport, visibility
    write_floor(tmp_path / "floor.obj", 49)
    p = tmp_path / "delta.yaml"
    ball = "model: ggx, params: {alpha: 0.25, kd: [0, 0, 0], ks: 0.7}"
    light = [0.6, 0.7, 0.3]
    p.write_text(textwrap.dedent(CONFIG.format(
        env=SAMPLES / "sky_sun.exr", ball=ball,
        extra=f"  environment_exposure: -30\n  lights:\n    - {{type: directional, "
              f"direction: {light}, intensity: [3, 3, 3]}}\n")))
    out = tmp_path / "out"
    cfg = load_config(p, ["render.supersample=1", "render.methods=[transport]"])
    for stage in (fit, envmap, visibility, transport, render):
        stage.run(cfg, out)
    gb = read_gbuffer(out / "render")
    img = read_image(out / "render", "transport")[..., :3]
    nrm, tng, x = gb.normal, gb.tangent, gb.position
    bit = np.cross(nrm, tng)
    eye = np.array([0.0, 2.6, 3.2])
    v = eye - x
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    l = np.array(light) / np.linalg.norm(light)
    local = lambda d: np.stack([(d * tng).sum(-1), (d * bit).sum(-1), (d * nrm).sum(-1)], -1)
    o, i = local(v), local(np.broadcast_to(l, v.shape))
    sel = gb.hit & (gb.object_id == 0) & (i[..., 2] > 0.3) & (o[..., 2] > 0.3)
    brdf = material_brdf(cfg.fit.materials[0])
    want = 3.0 * brdf.specular(o[sel], i[sel]) * i[sel][:, 2:3]
    got = img[sel]
    bright = want.mean(-1) > 0.05 * want.mean(-1).max()
    rel = np.abs(got[bright] - want[bright]).mean(-1) / want[bright].mean(-1)
    assert bright.sum() >= 30, bright.sum()
    assert np.percentile(rel, 95) <= 1e-3, (np.median(rel), np.percentile(rel, 95))
