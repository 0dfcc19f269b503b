"""The whole pipeline through the CLI: same config -> byte-identical artifacts; reruns skip."""

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tiny_scene import tiny_config  # tests/ is on sys.path

CONFIG = tiny_config("[sg, gmm, gmm_toral19, fis, reference]", workers=2)


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
    # every file but the timings, config.resolved.yaml and manifest.json included (neither
    # records the worker count: it does not change what is computed)
    differ = sorted(k for k in fa if fa[k] != fb.get(k))
    assert sorted(fa) == sorted(fb)
    assert differ == [], differ
    again = sgpipe("run", cfg, "--out", a)
    assert again.returncode == 0, again.stderr
    for stage in ("fit", "envmap", "visibility", "render"):
        assert f"[{stage}] up to date" in again.stderr, again.stderr
    assert _files(a) == fa


@pytest.mark.slow
def test_render_refuses_upstream_artifacts_made_for_another_config(tmp_path):
    """`sgpipe render --set` with a material or map parameter changed rendered with the fit /
    environment made for the old value, silently. It now names the stage and the first key
    that differs; the unchanged config still renders."""
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(textwrap.dedent(tiny_config("[sg]", workers=1)).replace(
        "compare_to: reference", "compare_to: null"))
    out = tmp_path / "o"
    r = sgpipe("run", cfg, "--out", out)
    assert r.returncode == 0, r.stderr
    for override, stage, key in (
            ("fit.materials.0.params.alpha=0.3", "fit", "fit.materials.0.params.alpha: 0.15 -> 0.3"),
            ("envmap.cube_resolution=8", "envmap", "envmap.cube_resolution"),
            ("scene.objects.0.sphere_radius=0.6", "visibility", "scene.objects.0.sphere_radius")):
        r = sgpipe("render", cfg, "--out", out, "--set", override)
        assert r.returncode == 2, r.stderr
        lines = [ln for ln in r.stderr.splitlines() if ln.startswith("sgpipe: error:")]
        assert len(lines) == 1 and f"{out / stage}: {stage}: was made for another config" \
            in lines[0] and key in lines[0], r.stderr
    r = sgpipe("render", cfg, "--out", out)
    assert r.returncode == 0 and "[render] up to date" in r.stderr, r.stderr
