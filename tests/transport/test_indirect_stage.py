"""The transport stage with `transport.indirect` (Green06 §4.1 eq 5) on a tiny ball-on-floor
scene: byte-identical artifacts across worker counts and chunkings (per-vertex random streams),
a convex object alone unchanged by the option (its indirect part is exactly zero), the
interreflected SH transfer taking the floor's colour, and `sgpipe run` rendering `transport`
from the indirect artifacts."""

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from sgpipe.artifacts import transport as contract
from sgpipe.config import load_config
from sgpipe.stages import transport as stage
from tiny_scene import write_floor  # tests/ is on sys.path

DATA = Path(__file__).resolve().parents[2] / "data_samples"
FLOOR_RGB = (0.6, 0.3, 0.15)

CONFIG = """
name: tri
seed: 3
workers: {workers}
scene:
  objects:
    - {{name: ball, sphere_radius: 0.5, translate: [0, 0.5, 0], material: ball}}
{floor}
fit:
  materials:
    - {{name: ball, model: ggx, params: {{alpha: 0.2, kd: 0.2, ks: 0.6, fresnel: none}}}}
    - {{name: floor, model: lambert, params: {{kd: [{rgb}]}}}}
transport:
  cube_resolution: 8
  sphere_subdivisions: 0
  chunk_vertices: {chunk}
  report_vertices: 0
  max_iterations: 10
  indirect: {indirect}
  indirect_bounces: {bounces}
  indirect_paths: 8
  indirect_transfer_paths: 2
"""
FLOOR = "    - {name: floor, mesh: floor.obj, material: floor}"


def run_stage(tmp_path, name, *, workers=1, chunk=16, indirect=True, floor=True, bounces=2):
    write_floor(tmp_path / "floor.obj", 4)
    p = tmp_path / f"{name}.yaml"
    p.write_text(textwrap.dedent(CONFIG.format(
        workers=workers, chunk=chunk, indirect=str(indirect).lower(), bounces=bounces,
        floor=FLOOR if floor else "", rgb=", ".join(map(str, FLOOR_RGB)))))
    out = tmp_path / name
    stage.run(load_config(p), out)
    return out / "transport"


def files(folder, obj, names=(contract.GAUSSIANS, contract.SH_TRANSFER)):
    return {n: (folder / obj / n).read_bytes() for n in names}


def test_indirect_artifacts_independent_of_workers_and_chunks(tmp_path):
    a = run_stage(tmp_path, "a", workers=1, chunk=16)
    b = run_stage(tmp_path, "b", workers=2, chunk=16)
    c = run_stage(tmp_path, "c", workers=1, chunk=5)
    for obj in ("ball", "floor"):
        assert files(a, obj) == files(b, obj), obj
        # the chunking decides the flood fill's starts (the Gaussians), never the random
        # streams: the path-traced transfer is the same bytes
        assert files(a, obj, (contract.SH_TRANSFER,)) == files(c, obj, (contract.SH_TRANSFER,))
    # and the indirect part is really there: the ball's underside sees the floor
    t, _ = contract.read_sh_transfer_rgb(a, "ball")
    shadowed, _ = contract.read_sh_transfer(a, "ball")
    assert np.abs(t - shadowed[..., None]).max() > 1e-3
    rep = json.loads((a / contract.REPORT).read_text())["objects"]
    assert rep["ball"]["sh_indirect_over_shadowed"] > 0.01


def test_convex_object_alone_is_unchanged_by_indirect(tmp_path):
    on = run_stage(tmp_path, "on", indirect=True, floor=False)
    off = run_stage(tmp_path, "off", indirect=False, floor=False)
    assert files(on, "ball") == files(off, "ball")
    t, _ = contract.read_sh_transfer_rgb(on, "ball")
    shadowed, _ = contract.read_sh_transfer(on, "ball")
    assert np.array_equal(t, np.repeat(shadowed[..., None], 3, axis=-1))


def test_interreflected_transfer_takes_the_floor_colour(tmp_path):
    """One bounce: every path that reaches the sky met exactly the Lambert floor once, whose
    importance-sampled weight f·cos/p is kd: the ball's indirect transfer is kd_c × one scalar
    transfer, so its channels stand in the floor's colour ratio to rounding."""
    out = run_stage(tmp_path, "col", bounces=1)
    t, _ = contract.read_sh_transfer_rgb(out, "ball")
    shadowed, _ = contract.read_sh_transfer(out, "ball")
    ind = t.astype(np.float64) - shadowed[..., None]
    assert np.abs(ind).max() > 1e-3
    rgb = np.asarray(FLOOR_RGB)
    scalar = ind[..., 0] / rgb[0]
    np.testing.assert_allclose(ind, scalar[..., None] * rgb, atol=2e-6 * np.abs(ind).max())
    # two bounces add paths floor → ball → floor: those carry kd², so the ratio moves away
    out2 = run_stage(tmp_path, "col2", bounces=2)
    t2, _ = contract.read_sh_transfer_rgb(out2, "ball")
    ind2 = t2.astype(np.float64) - shadowed[..., None]
    dc = ind2[:, 0, :]                    # the DC term: the mean indirect irradiance
    sel = np.abs(dc[:, 0]) > 1e-3
    assert np.all(dc[sel, 2] / dc[sel, 0] <= rgb[2] / rgb[0] + 1e-6)


def test_old_transfer_files_read_as_shadowed_only(tmp_path):
    from sgpipe.io import write_npz
    folder = tmp_path / "transport"
    t = np.random.default_rng(0).normal(size=(7, 25)).astype(np.float32)
    write_npz(folder / contract.object_file("o", contract.SH_TRANSFER),
              {"transfer": t, "lmax": np.int32(4), "diffuse_rgb": np.ones(3, np.float32)})
    full, _ = contract.read_sh_transfer_rgb(folder, "o")
    assert full.shape == (7, 25, 3) and np.array_equal(full[..., 1], t)


@pytest.mark.opencl
def test_kernel_sums_the_sh_transfer_per_colour_channel():
    """The `transport` kernel's diffuse part with an RGB transfer: per pixel and channel c,
    f_d,c Σ_k (Σ_i b_i t_i,k,c) L_k,c (the triangle blend of three vertices' transfer), against
    numpy to float32 rounding; a grey sum (channel 0 for all) would be far off."""
    from sgpipe.render.envdata import EnvData
    from sgpipe.render.materials import pack_materials
    from sgpipe.render.renderer import Frame, Renderer
    from sgpipe.render.transport_data import transport_arrays, upload_transport
    from sgpipe.transport.views import N_VIEWS
    rng = np.random.default_rng(5)
    P = 16
    t = rng.normal(0, 0.5, (3 * P, 25, 3)).astype(np.float32)
    light = rng.normal(0, 1.0, (25, 3)).astype(np.float32)
    light[0] += 4.0
    fd = np.array([0.3, 0.2, 0.1])
    z = np.zeros((3 * P, N_VIEWS, 1))
    obj = dict(mu=np.zeros((3 * P, N_VIEWS, 1, 3)), sigma=z, w=np.zeros((3 * P, N_VIEWS, 1, 3)),
               transfer=t, diffuse_rgb=fd, faces=np.arange(3 * P).reshape(P, 3))
    r = Renderer(env=EnvData.constant(np.ones(3)), materials=pack_materials([]), objects=[],
                 fh_mode="sigmoid")
    upload_transport(r, transport_arrays([obj], light.astype(np.float64)))
    bary = rng.dirichlet(np.ones(3), size=P)
    view = rng.normal(size=(P, 3))
    z4 = np.zeros((P, 4), np.float32)
    v4 = z4.copy()
    v4[:, :3] = view / np.linalg.norm(view, axis=1, keepdims=True)
    fr = Frame(index=np.arange(P), shape=(P,), normal=z4, tangent=z4, view=v4, position=z4,
               uv=np.zeros((P, 2), np.float32), obj=np.zeros(P, np.int32),
               tri=np.arange(P, dtype=np.int32), bary=bary[:, 1:].astype(np.float32))
    got = r.shade("transport", fr).astype(np.float64)
    tb = np.einsum("pi,pikc->pkc", bary, t.reshape(P, 3, 25, 3).astype(np.float64))
    want = fd * np.einsum("pkc,kc->pc", tb, light.astype(np.float64))
    np.testing.assert_allclose(got, want, atol=2e-5 * np.abs(want).max())
    grey = fd * np.einsum("pk,kc->pc", tb[..., 0], light.astype(np.float64))
    assert np.abs(grey - want).max() > 0.1 * np.abs(want).max()


@pytest.mark.opencl
@pytest.mark.slow
def test_sgpipe_run_renders_transport_with_indirect(tmp_path):
    """`sgpipe run` end to end: the fit, envmap, visibility and transport (indirect) stages and
    the render of `transport` beside the 1-bounce reference, compared by the render stage."""
    write_floor(tmp_path / "floor.obj", 4)
    cfg = textwrap.dedent(f"""
        name: tri_run
        seed: 0
        workers: 1
        scene:
          objects:
            - {{name: ball, sphere_radius: 0.5, translate: [0, 0.5, 0], material: ball}}
            - {{name: floor, mesh: floor.obj, material: floor}}
        fit:
          materials:
            - {{name: ball, model: ggx, params: {{alpha: 0.2, kd: 0.2, ks: 0.6, fresnel: none}}}}
            - {{name: floor, model: lambert, params: {{kd: [0.6, 0.3, 0.15]}}}}
          ndf_sg: {{report_lobes: 0}}
          view_gmm: {{lobes: 2, samples: 128, theta_count: 3, report_lobes: 0}}
        envmap: {{environment: {DATA / 'studio.exr'}, cube_resolution: 32}}
        visibility: {{trace_resolution: 16, resolution: 8, pca_terms: 4,
                     sphere_subdivisions: 1, report_vertices: 0, preview_vertices: 0}}
        transport: {{cube_resolution: 8, sphere_subdivisions: 1, indirect: true,
                    indirect_paths: 8, indirect_transfer_paths: 2, max_iterations: 10,
                    report_vertices: 0}}
        render:
          camera: {{eye: [0, 1.6, 4.2], target: [0, 0.4, 0], fov_deg: 34,
                   width: 32, height: 32}}
          methods: [transport, reference]
          reference_bounces: 2
          spp: 16
          compare_to: reference
          timing_repeats: 1
        """)
    (tmp_path / "c.yaml").write_text(cfg)
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(tmp_path / "c.yaml"),
                        "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    man = json.loads((out / "render" / "manifest.json").read_text())
    assert "transport" in man["report"]["compare"]
    assert (out / "render" / "transport.png").is_file()
    from sgpipe.io import read_exr
    img = np.asarray(read_exr(out / "render" / "transport.exr"))
    assert np.isfinite(img).all() and img.max() > 0
