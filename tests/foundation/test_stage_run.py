"""StageRun: manifest, skip when unchanged, --force, nothing half-written, determinism."""

import json
from pathlib import Path

import numpy as np
import pytest

from sgpipe.config import load_config
from sgpipe.errors import BadInput
from sgpipe.stages.base import StageRun


@pytest.fixture
def cfg(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("name: t\nseed: 1\n")
    return load_config(p)


def _run(cfg, out, params, inputs=(), force=False, fail=False):
    with StageRun(cfg, out, "demo", params=params, inputs=list(inputs), force=force) as run:
        if run.skipped:
            return run
        run.write_exr("img.exr", np.full((4, 5, 3), params["v"], np.float32))
        run.write_npz("a.npz", {"x": np.arange(3) * params["v"]})
        run.report["mean"] = float(params["v"])
        run.timings["work_s"] = 0.1
        if fail:
            raise RuntimeError("stage crashed")
    return run


def test_manifest_and_outputs(cfg, tmp_path):
    out = tmp_path / "out"
    _run(cfg, out, {"v": 2.0})
    d = out / "demo"
    names = sorted(p.name for p in d.iterdir())
    assert names == ["a.npz", "config.resolved.yaml", "img.exr", "img.png", "manifest.json",
                     "timings.json"]
    man = json.loads((d / "manifest.json").read_text())
    assert man["report"] == {"mean": 2.0} and man["params"] == {"v": 2.0}
    assert set(man["outputs"]) == {"a.npz", "config.resolved.yaml", "img.exr", "img.png"}
    assert not any(p.name.startswith(".") for p in out.iterdir())


def test_skip_when_unchanged_and_rerun_on_change(cfg, tmp_path, capsys):
    out = tmp_path / "out"
    inp = tmp_path / "in.txt"
    inp.write_text("a")
    assert not _run(cfg, out, {"v": 1.0}, [inp]).skipped
    assert _run(cfg, out, {"v": 1.0}, [inp]).skipped
    assert "up to date" in capsys.readouterr().err
    assert not _run(cfg, out, {"v": 1.0}, [inp], force=True).skipped
    assert not _run(cfg, out, {"v": 3.0}, [inp]).skipped          # parameters changed
    inp.write_text("b")
    assert not _run(cfg, out, {"v": 3.0}, [inp]).skipped          # input content changed
    (out / "demo" / "a.npz").write_bytes(b"tampered")
    assert not _run(cfg, out, {"v": 3.0}, [inp]).skipped          # output damaged


def test_code_change_reruns(cfg, tmp_path, monkeypatch):
    """The cache key includes a hash of sgpipe's own code: artifacts made by older code are not
    reused (a stale fit once survived a code change this way)."""
    import sgpipe.stages.base as base
    out = tmp_path / "out"
    assert not _run(cfg, out, {"v": 1.0}).skipped
    assert _run(cfg, out, {"v": 1.0}).skipped
    monkeypatch.setattr(base, "code_hash", lambda: "0123456789abcdef")
    assert not _run(cfg, out, {"v": 1.0}).skipped
    assert _run(cfg, out, {"v": 1.0}).skipped


def test_code_hash_covers_python_and_kernels():
    import sgpipe.stages.base as base
    names = {p.name for p in base.code_files()}
    assert {"base.py", "cli.py", "sg_shade.cl", "cubemap.h"} <= names
    assert not any(p.suffix == ".pyc" for p in base.code_files())


def test_failure_leaves_previous_outputs_untouched(cfg, tmp_path):
    out = tmp_path / "out"
    _run(cfg, out, {"v": 1.0})
    before = {p.name: p.read_bytes() for p in (out / "demo").iterdir()}
    with pytest.raises(RuntimeError):
        _run(cfg, out, {"v": 5.0}, fail=True)
    after = {p.name: p.read_bytes() for p in (out / "demo").iterdir()}
    assert after == before
    assert sorted(p.name for p in out.iterdir()) == ["demo"]


def test_failure_on_first_run_writes_nothing(cfg, tmp_path):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError):
        _run(cfg, out, {"v": 5.0}, fail=True)
    assert not out.exists()          # the folder the run created is removed again


@pytest.mark.parametrize("exc", [KeyboardInterrupt, SystemExit])
def test_interrupt_removes_staging_and_scratch(cfg, tmp_path, exc):
    """KeyboardInterrupt / SystemExit (what signals become) clean up like any failure."""
    out = tmp_path / "out"
    _run(cfg, out, {"v": 1.0})
    before = {p.name: p.read_bytes() for p in (out / "demo").iterdir()}
    with pytest.raises(exc):
        with StageRun(cfg, out, "demo", params={"v": 2.0}) as run:
            (run.scratch_dir() / "big.f32").write_bytes(b"x" * 100)
            run.write_npz("a.npz", {"x": np.zeros(3)})
            raise exc()
    assert sorted(p.name for p in out.iterdir()) == ["demo"]
    assert {p.name: p.read_bytes() for p in (out / "demo").iterdir()} == before


def test_scratch_removed_after_success_and_leftovers_of_a_killed_run(cfg, tmp_path):
    out = tmp_path / "out"
    for name in (".demo.staging", ".demo.tmp", ".demo.tmpab12cd", ".demo.old"):
        (out / name).mkdir(parents=True)          # what a SIGKILLed run leaves
        (out / name / "f").write_text("stale")
    with StageRun(cfg, out, "demo", params={"v": 1.0}) as run:
        (run.scratch_dir() / "tmp.npy").write_bytes(b"scratch")
        run.write_json("r.json", {"a": 1})
    assert sorted(p.name for p in out.iterdir()) == ["demo"]
    assert "tmp.npy" not in json.loads((out / "demo" / "manifest.json").read_text())["outputs"]


@pytest.mark.parametrize("damage", ["delete", "truncate", "empty"])
def test_damaged_output_reruns(cfg, tmp_path, damage, capsys):
    out = tmp_path / "out"
    _run(cfg, out, {"v": 1.0})
    good = (out / "demo" / "img.exr").read_bytes()
    target = out / "demo" / "img.exr"
    if damage == "delete":
        target.unlink()
    else:
        target.write_bytes(good[: len(good) // 2] if damage == "truncate" else b"")
    capsys.readouterr()
    assert not _run(cfg, out, {"v": 1.0}).skipped
    assert "missing or changed" in capsys.readouterr().err
    assert target.read_bytes() == good
    assert _run(cfg, out, {"v": 1.0}).skipped


def test_unreadable_output_reruns(cfg, tmp_path, capsys, monkeypatch):
    """An artifact that cannot be read (mode 000 for a non-root user; root reads through it,
    so the read error is injected here) made the skip check a PermissionError traceback."""
    import sgpipe.stages.base as base
    out = tmp_path / "out"
    _run(cfg, out, {"v": 1.0})
    real = base.file_hash

    def denied(p, *a):
        if Path(p) == out / "demo" / "img.exr":      # the published one, not the rerun's
            raise PermissionError(13, "Permission denied", str(p))
        return real(p, *a)

    monkeypatch.setattr(base, "file_hash", denied)
    capsys.readouterr()
    assert not _run(cfg, out, {"v": 1.0}).skipped
    assert "img.exr is unreadable (Permission denied): rerunning" in capsys.readouterr().err


def test_empty_npz_is_one_line_naming_it(tmp_path):
    """np.load raises EOFError on an empty file, which click turned into a bare 'aborted'."""
    from sgpipe.io import read_npz
    p = tmp_path / "ndf_sg.npz"
    p.write_bytes(b"")
    with pytest.raises(BadInput, match="unreadable NPZ") as e:
        read_npz(p, key="fit.ndf_sg")
    assert e.value.file == str(p) and e.value.key == "fit.ndf_sg"


def test_manifest_without_outputs_is_not_up_to_date(cfg, tmp_path):
    out = tmp_path / "out"
    _run(cfg, out, {"v": 1.0})
    man = out / "demo" / "manifest.json"
    m = json.loads(man.read_text())
    del m["outputs"]
    man.write_text(json.dumps(m))
    assert not _run(cfg, out, {"v": 1.0}).skipped
    man.write_text("[1, 2]")
    assert not _run(cfg, out, {"v": 1.0}).skipped


def test_input_keys_do_not_depend_on_the_output_folder(tmp_path):
    """Inputs inside the output folder are keyed `<out>/...`, others relative to the config's
    folder: the same config into two output folders gives byte-identical manifests."""
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "mesh.obj").write_text("v 0 0 0\n")
    (tmp_path / "cfgs").mkdir()
    p = tmp_path / "cfgs" / "c.yaml"
    p.write_text("name: t\nseed: 1\n")
    cfg = load_config(p)
    trees = []
    for out in (tmp_path / "a", tmp_path / "deeper" / "b"):
        _run(cfg, out, {"v": 1.0})
        with StageRun(cfg, out, "next", params={}, inputs=[
                out / "demo" / "manifest.json", tmp_path / "data" / "mesh.obj"]) as run:
            run.write_json("r.json", {})
        man = json.loads((out / "next" / "manifest.json").read_text())
        assert sorted(man["inputs"]) == ["<config>/../data/mesh.obj", "<out>/demo/manifest.json"]
        trees.append({f.relative_to(out).as_posix(): f.read_bytes() for f in out.rglob("*")
                      if f.is_file() and f.name != "timings.json"})
    assert trees[0] == trees[1]


def test_folder_lock_is_reentrant_and_exclusive(tmp_path):
    import fcntl
    import os

    from sgpipe.stages.base import folder_lock
    out = tmp_path / "out"
    out.mkdir()                         # (a folder the lock created and left empty is removed)
    with folder_lock(out):
        with folder_lock(out):          # StageRun inside the CLI's lock
            pass
        fd = os.open(out, os.O_RDONLY)
        try:                            # another open file (another process) cannot take it
            with pytest.raises(BlockingIOError):
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(fd)
    fd = os.open(out, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)   # released
    finally:
        os.close(fd)


def test_same_inputs_give_byte_identical_artifacts(cfg, tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    _run(cfg, a, {"v": 1.5})
    _run(cfg, b, {"v": 1.5})
    for p in (a / "demo").iterdir():
        if p.name != "timings.json":
            assert p.read_bytes() == (b / "demo" / p.name).read_bytes(), p.name


def test_unwritable_output_is_bad_input(cfg, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(BadInput, match="not writable") as e:
        _run(cfg, blocker / "out", {"v": 1.0})
    assert e.value.key == "--out"


def test_missing_input_is_bad_input(cfg, tmp_path):
    with pytest.raises(BadInput, match="input file not found"):
        _run(cfg, tmp_path / "out", {"v": 1.0}, [tmp_path / "gone.exr"])


def test_signal_during_publish_lands_after_it(cfg, tmp_path, monkeypatch):
    """A Ctrl-C while the outputs are hashed and the folders swapped is delivered once the
    stage is published in full: never a half-swapped folder."""
    import os
    import signal

    import sgpipe.stages.base as base
    real, sent = base.file_hash, []

    def hash_and_interrupt(p):
        if not sent:
            sent.append(p)
            os.kill(os.getpid(), signal.SIGINT)
        return real(p)

    monkeypatch.setattr(base, "file_hash", hash_and_interrupt)
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        _run(cfg, out, {"v": 1.0})
    assert sent
    assert sorted(p.name for p in out.iterdir()) == ["demo"]
    man = json.loads((out / "demo" / "manifest.json").read_text())
    assert all(real(out / "demo" / n) == h for n, h in man["outputs"].items())
