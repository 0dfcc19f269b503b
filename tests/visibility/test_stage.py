"""The visibility stage end to end on a tiny scene: contract, exactness, determinism."""

import json
import textwrap

import numpy as np
import pytest

from sgpipe.artifacts import visibility as contract
from sgpipe.config import load_config
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz
from sgpipe.stages import visibility as stage
from sgpipe.visibility import decode_ssdf
from sgpipe.visibility.hemigrid import texel_dirs
from sgpipe.visibility.ssdf import ssdf_from_visibility
from sgpipe.visibility.trace import build_scene, trace_visibility
from tiny_scene import write_floor  # tests/ is on sys.path

CONFIG = """
name: vis
seed: 3
workers: {workers}
scene:
  objects:
    - {{name: floor, mesh: floor.obj, material: m}}
    - {{name: ball, sphere_radius: 0.5, translate: [0.2, 0.5, 0.1]}}
visibility:
  trace_resolution: 32
  resolution: 8
  pca_terms: {terms}
  sphere_subdivisions: 0
  report_vertices: 2
  report_directions: 2
  report_lambdas: [10, 100]
  report_samples: 256
  preview_vertices: 2
"""


def make(tmp_path, workers=1, terms=64):
    write_floor(tmp_path / "floor.obj", 6)
    p = tmp_path / "c.yaml"
    p.write_text(textwrap.dedent(CONFIG.format(workers=workers, terms=terms)))
    return load_config(p)


def test_artifacts_follow_the_contract_and_decode_exactly(tmp_path):
    cfg = make(tmp_path)
    out = tmp_path / "out"
    stage.run(cfg, out)
    vis_dir = out / "visibility"
    man = json.loads((vis_dir / "manifest.json").read_text())
    rep = json.loads((vis_dir / "report.json").read_text())
    assert set(rep["objects"]) == {"floor", "ball"}
    geo = read_npz(vis_dir / "ball/geometry.npz", required=(
        "positions", "normals", "tangents", "bitangents", "faces", "uvs", "has_uvs",
        "ray_offset"))
    pca = read_npz(vis_dir / "ball/ssdf_pca.npz", required=(
        "mean", "basis", "coeffs", "explained_variance", "resolution", "trace_resolution",
        "max_distance"))
    V = len(geo["positions"])
    assert V == 12 and pca["basis"].shape == (12, 8, 8) and pca["coeffs"].shape == (V, 12)
    assert pca["resolution"].item() == 8 and pca["trace_resolution"].item() == 32
    np.testing.assert_allclose(geo["bitangents"], np.cross(geo["normals"], geo["tangents"]),
                               atol=1e-6)
    mean_exr = read_exr(vis_dir / "ball/eigen/ssdf_mean.exr")
    np.testing.assert_array_equal(mean_exr[..., 0], pca["mean"])
    e3 = read_exr(vis_dir / "ball/eigen/ssdf_eigen_03.exr")
    np.testing.assert_array_equal(e3[..., 0], pca["basis"][3])
    assert (vis_dir / "ball/eigen/ssdf_eigen_03.png").is_file()
    assert len(list((vis_dir / "floor/previews").glob("vertex_*.png"))) == 2
    assert "ball/ssdf_pca.npz" in man["outputs"]
    # the renderer's readers accept what the stage wrote
    assert contract.read_geometry(vis_dir, "ball").faces.shape == geo["faces"].shape
    assert contract.read_ssdf_pca(vis_dir, "ball").basis.shape == (12, 8, 8)
    # all terms kept (12 vertices) => the decoder reproduces a direct trace at texel centres
    floor = read_npz(vis_dir / "floor/geometry.npz")
    tri = np.concatenate([floor["positions"][floor["faces"]], geo["positions"][geo["faces"]]])
    scene = build_scene(tri)
    q = texel_dirs(8)
    for i in (0, 5, 11):
        n, t, b = geo["normals"][i], geo["tangents"][i], geo["bitangents"][i]
        vis = trace_visibility(scene, geo["positions"][i], n, t, b, 32, geo["ray_offset"].item())
        direct = ssdf_from_visibility(vis, 8)
        w = q[..., :1] * t + q[..., 1:2] * b + q[..., 2:] * n
        dec = decode_ssdf(w, pca["coeffs"][i], pca["mean"], pca["basis"], n, t)
        np.testing.assert_allclose(dec, direct, atol=2e-4)
    assert rep["objects"]["floor"]["products"]["10"]["n"] == 4


def test_parallel_workers_and_reruns_are_byte_identical(tmp_path):
    out1, out2 = tmp_path / "o1", tmp_path / "o2"
    stage.run(make(tmp_path, workers=1, terms=3), out1)
    stage.run(make(tmp_path, workers=2, terms=3), out2)
    m1 = json.loads((out1 / "visibility/manifest.json").read_text())["outputs"]
    m2 = json.loads((out2 / "visibility/manifest.json").read_text())["outputs"]
    for name in m1:
        if name != "config.resolved.yaml":     # it records `workers`
            assert m1[name] == m2[name], name
    run = stage.run(make(tmp_path, workers=1, terms=3), out1)
    assert run.skipped


def test_missing_scene_is_bad_input(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("visibility: {trace_resolution: 16, resolution: 8}\n")
    with pytest.raises(BadInput, match="scene"):
        stage.run(load_config(p), tmp_path / "out")


def test_resolution_must_divide_trace_resolution(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("visibility: {trace_resolution: 20, resolution: 8}\n")
    with pytest.raises(BadInput, match="divide"):
        load_config(p)


def test_adaptive_sampling_writes_the_same_artifacts_as_full(tmp_path):
    """The default sampling (adaptive) writes what `full` writes, from < 20 % of its rays."""
    out_full, out_ad = tmp_path / "full", tmp_path / "adaptive"
    full = make(tmp_path, terms=3)
    full.visibility.sampling = "full"
    stage.run(full, out_full)
    cfg = make(tmp_path, terms=3)
    assert cfg.visibility.sampling == "adaptive"
    run = stage.run(cfg, out_ad)
    m1 = json.loads((out_full / "visibility/manifest.json").read_text())["outputs"]
    m2 = json.loads((out_ad / "visibility/manifest.json").read_text())["outputs"]
    same = [n for n in m1 if n.endswith((".npz", ".png"))]
    assert any(n.endswith("ssdf_pca.npz") for n in same) and len(same) > 10
    for name in same:
        assert m1[name] == m2[name], name
    for name in (n for n in m1 if n.endswith(".exr")):   # their headers hash the parameters
        np.testing.assert_array_equal(read_exr(out_full / "visibility" / name),
                                      read_exr(out_ad / "visibility" / name))
    rays = [json.loads((o / "visibility/manifest.json").read_text())["report"]["rays"]
            for o in (out_full, out_ad)]
    assert rays[0] == 48 * 32 * 32 and rays[1] < 0.2 * rays[0], rays
    assert run.report["rays"] == rays[1]
