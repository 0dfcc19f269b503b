"""`transport`'s environment glossy term (kernels/transport_shade.cl): the BRDF's own lobes at
the pixel (sg_specular.h, no SSDF) times the fitted transport's visibility, the ratio of the
shadowed to the unshadowed Gaussians (transport.sampling: lobe stores both) under the same
light. Proven on a GGX ball on a Lambert floor under the studio map: the unshadowed set equals
the shadowed one wherever nothing occludes the vertex and carries at least its integral
elsewhere; where nothing occludes, the ratio is 1 and the term is sg's unshadowed specular to
float rounding; `transport_green06` with every improvement given back is `transport`; against
the reference the ratio and the exact BRDF at a directional light beat Green06's published
rendering (Σ w Γ_L of the Gaussians, w G(l) E)."""

import json
import textwrap

import numpy as np
import pytest

from sgpipe.config import load_config
from tiny_scene import SAMPLES, write_floor  # tests/ is on sys.path

pytestmark = pytest.mark.opencl

CONFIG = """
name: ratio
seed: 1
workers: 1
scene:
  objects:
    - {name: ball, sphere_radius: 0.5, translate: [0, 0.5, 0], material: ball}
    - {name: floor, mesh: floor.obj, material: floor}
fit:
  materials:
    - {name: ball, model: ggx, params: {alpha: 0.12, kd: [0, 0, 0], ks: 0.8}}
    - {name: floor, model: ggx, params: {alpha: 0.2, kd: [0.2, 0.2, 0.2], ks: 0.5}}
  ndf_sg: {report_lobes: 0}
  view_gmm: {report_lobes: 0, holdout: false}
envmap: {environment: STUDIO, cube_resolution: 32}
visibility: {trace_resolution: 32, resolution: 16, pca_terms: 8, sphere_subdivisions: 2}
transport: {cube_resolution: 8, sphere_subdivisions: 2, report_vertices: 0}
render:
  camera: {eye: [0, 1.6, 2.6], target: [0, 0.3, 0], fov_deg: 42, width: 40, height: 40}
  methods: [transport, transport_green06, reference]
  environment_exposure: -2
  spp: 128
  supersample: 2
  compare_to: reference
  lights:
    - {type: directional, direction: [0.5, 0.8, 0.3], intensity: [0.3, 0.3, 0.3]}
"""


def _run(tmp, floor: bool):
    from sgpipe.stages import envmap, fit, render, transport, visibility
    write_floor(tmp / "floor.obj", 25)
    text = CONFIG.replace("STUDIO", str(SAMPLES / "studio.exr"))
    if not floor:        # the ball alone: nothing occludes any vertex
        text = text.replace("    - {name: floor, mesh: floor.obj, material: floor}\n", "")
        text = text.replace("[transport, transport_green06, reference]", "[transport]")
        text = text.replace("compare_to: reference", "compare_to: null")
    p = tmp / "c.yaml"
    p.write_text(textwrap.dedent(text))
    out = tmp / "out"
    cfg = load_config(p)
    for stage in (fit, envmap, visibility, transport, render):
        stage.run(cfg, out)
    return p, out


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("ratio"), floor=True)


@pytest.fixture(scope="module")
def lone(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("ratio_lone"), floor=False)


def _integral(mu, sigma, w):
    from sgpipe.transport.interp import lobe_area
    return (w.mean(-1) * lobe_area(sigma)).sum(-1)             # (X, 92)


def test_open_set_where_occluded_only(run, lone):
    """The unshadowed Gaussians equal the shadowed ones at every vertex nothing occludes (the
    ball alone: same samples, same rule), are stored only where they differ (with the floor:
    its vertices round the ball, the ball's vertices whose grazing lobes reach it), and there
    carry at least the shadowed integral in every view (occlusion only removes transport)."""
    from sgpipe.artifacts.transport import read_gaussians, read_packed_gaussians
    assert read_packed_gaussians(lone[1] / "transport", "ball")["open_same"].all()
    _, out = run
    folder = out / "transport"
    for obj in ("ball", "floor"):
        shadowed = read_gaussians(folder, obj)[:3]
        opened = read_gaussians(folder, obj, open_set=True)[:3]
        same = read_packed_gaussians(folder, obj)["open_same"].astype(bool)
        for a, b in zip(opened, shadowed):
            np.testing.assert_array_equal(a[same], b[same])
        assert (~same).any(), obj
        i_open, i_sh = _integral(*opened), _integral(*shadowed)
        # as stored: σ's 8-bit log code (2.3 % steps, w·A(σ) off by up to ~2.3 % each way)
        assert (i_open >= i_sh * 0.95 - 1e-9).all(), obj
        assert (i_open[~same] > i_sh[~same] * 1.05).any(), obj


def _shade(p, out, method, overrides=(), flags=0):
    from sgpipe.render.methods import METHODS
    from sgpipe.render.renderer import Frame
    from sgpipe.render.scene import ssdf_triangles
    from sgpipe.render.setup import build_scene
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import Tracer
    cfg = load_config(p, list(overrides))
    b = build_scene(cfg, out, [METHODS["transport"], METHODS["sg"], METHODS[method]])
    gb = Tracer(b.objects).trace(*Camera.from_spec(cfg.render.camera).rays())
    fr = Frame.from_gbuffer(gb, *ssdf_triangles(gb, b.objects, b.proxies))
    return b.renderer.shade(method, fr, flags=flags).astype(np.float64), fr


def test_ratio_is_one_where_nothing_occludes(run, lone):
    """Environment specular only, SSDF off: on the ball alone `transport` equals `sg` without
    its energy tables (the same sg_specular.h lobes, the ratio exactly 1) to float rounding; with the ball on the floor, so
    is the floor wherever its triangle's vertices are open."""
    from sgpipe.artifacts.transport import read_packed_gaussians
    from sgpipe.io import read_npz
    from sgpipe.render.records import KernelFlag
    from sgpipe.render.methods import WANG09_SWITCHES
    flags = int(KernelFlag.NO_ENV_DIFFUSE | KernelFlag.NO_VISIBILITY)
    # sg without its energy tables (transport keeps the lobes' own energy): sg_wang09 given
    # back every other improvement
    no_energy = ("render.sg_wang09_adds=[" + ", ".join(
        k for k in WANG09_SWITCHES if k != "energy") + "]",)
    tp, fr = _shade(*lone, "transport", flags=flags)
    sg, _ = _shade(*lone, "sg_wang09", no_energy, flags=flags)
    ball = fr.obj == 0
    assert ball.sum() > 200
    np.testing.assert_allclose(tp[ball], sg[ball], rtol=1e-4, atol=1e-6)
    tp, fr = _shade(*run, "transport", flags=flags)
    sg, _ = _shade(*run, "sg_wang09", no_energy, flags=flags)
    folder = run[1] / "transport"
    same = read_packed_gaussians(folder, "floor")["open_same"].astype(bool)
    faces = read_npz(folder / "floor" / "geometry.npz")["faces"]
    floor = fr.obj == 1
    tri_same = same[faces[np.where(floor, fr.tri, 0)]].all(-1)
    np.testing.assert_allclose(tp[floor & tri_same], sg[floor & tri_same], rtol=1e-4, atol=1e-6)
    assert (floor & ~tri_same).any()


def test_green06_with_every_add_is_transport(run):
    """transport_green06 with every switch of GREEN06_SWITCHES given back renders `transport`
    bit for bit; each switch alone changes the image."""
    from sgpipe.render.methods import GREEN06_SWITCHES
    p, out = run
    full, _ = _shade(p, out, "transport")
    adds = sorted(GREEN06_SWITCHES)
    back, _ = _shade(p, out, "transport_green06",
                     [f"render.transport_green06_adds=[{','.join(adds)}]"])
    np.testing.assert_array_equal(back, full)
    published, _ = _shade(p, out, "transport_green06")
    for a in adds:
        one, _ = _shade(p, out, "transport_green06", [f"render.transport_green06_adds=[{a}]"])
        assert not np.array_equal(one, published), a


def test_ratio_beats_the_published_rendering(run):
    """Surface display PSNR against the 2×2-supersampled 128-spp reference (exposure −2):
    `transport` at least 1.5 dB over `transport_green06` on this scene (measured 40.21 and
    38.21 dB)."""
    _, out = run
    comp = json.loads((out / "render" / "manifest.json").read_text())["report"]["compare"]
    got = {m: comp[m]["surface"]["display_psnr_db"] for m in ("transport", "transport_green06")}
    assert got["transport"] >= got["transport_green06"] + 1.5, got
