"""The whole pipeline through the CLI: same config -> byte-identical artifacts; reruns skip."""

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tiny_scene import tiny_config  # tests/ is on sys.path

CONFIG = tiny_config("[sg, gmm, fis, reference]", workers=2)


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
