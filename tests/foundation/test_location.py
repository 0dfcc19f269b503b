"""Artifacts do not depend on where the checkout, the config or the output folder sit."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CONFIG = """name: loc
seed: 0
scene:
  objects:
    - {name: ball, sphere_radius: 0.5, material: m}
fit:
  materials:
    - {name: m, model: ggx, params: {alpha: 0.3}}
  view_gmm: {lobes: 2, samples: 256, theta_count: 3, report_lobes: 0}
  ndf_sg: {report_lobes: 0}
envmap:
  environment: data/studio.exr
  cube_resolution: 16
"""


def _tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != "timings.json"}


def test_same_config_elsewhere_gives_the_same_bytes(tmp_path):
    trees = []
    for place in ("a", "b/deeper/still"):
        home = tmp_path / place
        (home / "data").mkdir(parents=True)
        shutil.copy(ROOT / "data_samples" / "studio.exr", home / "data" / "studio.exr")
        (home / "cfg.yaml").write_text(CONFIG)
        out = tmp_path / f"out-{len(trees)}"
        r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(home / "cfg.yaml"),
                            "--out", str(out)], capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr
        trees.append(_tree(out))
    a, b = trees
    assert a.keys() == b.keys() and "envmap/pyramid/level_00.exr" in a
    assert [k for k in a if a[k] != b[k]] == []
    resolved = a["envmap/config.resolved.yaml"].decode()
    assert "environment: data/studio.exr" in resolved and str(tmp_path) not in resolved
