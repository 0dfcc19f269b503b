"""The whole pipeline through the CLI: same config -> byte-identical artifacts; reruns skip."""

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

SAMPLES = Path(__file__).resolve().parents[1] / "data_samples"

CONFIG = f"""
name: tiny
seed: 3
workers: 2
scene:
  objects:
    - {{name: ball, sphere_radius: 0.5, translate: [0, 0.5, 0], material: shiny}}
    - {{name: floor, mesh: {SAMPLES / 'floor.obj'}, scale: 0.4, material: matte}}
fit:
  materials:
    - {{name: shiny, model: ward, params: {{alpha: 0.15, kd: [0.2, 0.1, 0.05], ks: 0.6}}}}
    - {{name: matte, model: lambert, params: {{kd: [0.5, 0.5, 0.5]}}}}
  ndf_sg: {{report_lobes: 0}}
  view_gmm: {{lobes: 4, samples: 256, theta_count: 4, report_lobes: 0}}
envmap:
  environment: {SAMPLES / 'studio.exr'}
  cube_resolution: 16
visibility: {{trace_resolution: 16, resolution: 8, pca_terms: 4, sphere_subdivisions: 2}}
render:
  camera: {{eye: [0, 1.2, 3], target: [0, 0.4, 0], fov_deg: 40, width: 24, height: 16}}
  methods: [sg, gmm, fis, reference]
  lights: [{{type: point, position: [1, 3, 1], intensity: [5, 5, 5], radius: 0.1}}]
  spp: 4
  compare_to: reference
"""


def sgpipe(*args):
    return subprocess.run([sys.executable, "-m", "sgpipe", *map(str, args)],
                          capture_output=True, text=True, timeout=600)


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name != "timings.json"}


@pytest.mark.slow
def test_same_config_gives_byte_identical_artifacts_and_reruns_skip(tmp_path):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(textwrap.dedent(CONFIG))
    a, b = tmp_path / "a", tmp_path / "b"
    ra = sgpipe("run", cfg, "--out", a)
    assert ra.returncode == 0, ra.stderr
    rb = sgpipe("run", cfg, "--out", b, "--set", "workers=1")
    assert rb.returncode == 0, rb.stderr
    fa, fb = _files(a), _files(b)
    stages = {k.split("/")[0] for k in fa}
    assert stages == {"fit", "envmap", "visibility", "render"}
    assert any(k.endswith(".exr") for k in fa) and any(k.endswith(".npz") for k in fa)
    # config.resolved.yaml records `workers`, the one difference between the two runs
    differ = sorted(k for k in fa if fa[k] != fb.get(k) and not k.endswith("config.resolved.yaml")
                    and not k.endswith("manifest.json"))
    assert sorted(fa) == sorted(fb)
    assert differ == [], differ
    again = sgpipe("run", cfg, "--out", a)
    assert again.returncode == 0, again.stderr
    for stage in ("fit", "envmap", "visibility", "render"):
        assert f"[{stage}] up to date" in again.stderr, again.stderr
    assert _files(a) == fa
