"""Two `sgpipe run`s on one output folder (as `make -j` starts them): the second waits for the
first, then reuses its stages; the result is complete and byte-identical — manifests included —
to the same config run into another folder. A deleted or truncated artifact reruns its stage."""

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tiny_scene import SAMPLES, tiny_config  # tests/ is on sys.path
CONFIG = tiny_config("[sg, reference]")
STAGES = ("fit", "envmap", "visibility", "render")


def tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name != "timings.json"}


def run_together(*argvs):
    procs = [subprocess.Popen([sys.executable, "-m", "sgpipe", *map(str, a)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
             for a in argvs]
    return [(p.wait(timeout=600), p.stderr.read()) for p in procs]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two runs on `shared/`, started together, and one on `elsewhere/deeper/`."""
    root = tmp_path_factory.mktemp("concurrent")
    cfg = root / "tiny.yaml"
    cfg.write_text(textwrap.dedent(CONFIG))
    shared, other = root / "shared", root / "elsewhere" / "deeper"
    results = run_together(("run", cfg, "--out", shared), ("run", cfg, "--out", shared),
                           ("run", cfg, "--out", other))
    return cfg, shared, other, results


def test_second_run_waits_then_reuses(runs):
    cfg, shared, other, results = runs
    for rc, err in results:
        assert rc == 0, err
    waited = [err for _, err in results[:2] if "waiting for another sgpipe run" in err]
    assert len(waited) == 1, [err for _, err in results[:2]]
    lines = waited[0].splitlines()
    assert sum("waiting for another sgpipe run" in ln for ln in lines) == 1
    for stage in STAGES:
        assert f"[{stage}] up to date" in waited[0], waited[0]
    assert "waiting" not in results[2][1]


def test_artifacts_complete_and_independent_of_the_output_folder(runs):
    """Every stage of the shared folder is complete, with no staging or temp folder, and the
    bytes equal those of the run into another folder, manifests included (their input keys are
    relative: `<out>/…`, `<config>/…`)."""
    cfg, shared, other, _ = runs
    a, b = tree(shared), tree(other)
    assert {k.split("/")[0] for k in a} == set(STAGES)
    assert sorted(p.name for p in shared.iterdir()) == sorted(STAGES)
    assert sorted(a) == sorted(b)
    assert [k for k in a if a[k] != b[k]] == []
    assert any(k.endswith("manifest.json") for k in a)
    inputs = json.loads((shared / "render" / "manifest.json").read_text())["inputs"]
    assert "<out>/envmap/manifest.json" in inputs
    assert "<config>/" + os.path.relpath(SAMPLES / "floor.obj", cfg.parent) in inputs
    assert all(k.startswith(("<out>/", "<config>/")) for k in inputs), inputs


def test_damaged_artifacts_rerun_their_stage(runs, tmp_path):
    """A copy of the folder is still up to date; deleting one envmap file and truncating one
    visibility file makes the next run redo exactly those two stages, and the result is whole
    again."""
    cfg, shared, other, _ = runs
    x = tmp_path / "copy"
    shutil.copytree(shared, x)
    envmap_file = sorted(p for p in (x / "envmap").rglob("*.exr"))[0]
    envmap_file.unlink()
    vis_file = sorted((x / "visibility").rglob("ssdf_pca.npz"))[0]
    vis_file.write_bytes(vis_file.read_bytes()[:100])
    rc, err = run_together(("run", cfg, "--out", x))[0]
    assert rc == 0, err
    for stage in ("envmap", "visibility"):
        assert f"[{stage}] running" in err, err
    for stage in ("fit", "render"):
        assert f"[{stage}] up to date" in err, err
    assert tree(x) == tree(other)
