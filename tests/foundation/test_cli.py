"""Bad input through the real CLI: one line naming file and key, exit 2, nothing written.
Signal handling of the entry point (the subprocess tests are in test_signals.py)."""

import ctypes
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from sgpipe.io import write_exr


def sgpipe(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "sgpipe", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def assert_bad_input(res, *needles):
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("sgpipe: error:")]
    assert len(lines) == 1, res.stderr
    assert "Traceback" not in res.stderr
    for n in needles:
        assert n in lines[0], lines[0]


def write(tmp_path, text, name="c.yaml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def test_help_on_every_command():
    for cmd in ([], ["fit"], ["precompute"], ["render"], ["run"], ["compare"], ["doctor"],
                ["config-doc"]):
        res = sgpipe(*cmd, "--help")
        assert res.returncode == 0 and "Usage:" in res.stdout, cmd


@pytest.mark.parametrize("text,needle", [
    ("name: [x\n", "malformed YAML"),
    ("name: x\nunknown_key: 3\n", "unknown_key: unknown key"),
    ("seed: many\n", "seed: expected an integer"),
])
def test_config_errors(tmp_path, text, needle):
    p = write(tmp_path, text)
    out = tmp_path / "out"
    res = sgpipe("run", p, "--out", out)
    assert_bad_input(res, str(p), needle)
    assert not out.exists()


def test_missing_config_file(tmp_path):
    assert_bad_input(sgpipe("fit", tmp_path / "none.yaml"), "none.yaml", "not found")


def test_bad_override(tmp_path):
    p = write(tmp_path, "name: x\n")
    assert_bad_input(sgpipe("run", p, "--set", "seed=abc", "--out", tmp_path / "o"), "seed")


def _env_config(tmp_path, env_name):
    return write(tmp_path, f"envmap:\n  environment: {env_name}\n")


def test_nonfinite_environment_exr(tmp_path):
    img = np.ones((8, 16, 3), np.float32)
    img[3, 4, 0] = np.nan
    write_exr(tmp_path / "env.exr", img)
    out = tmp_path / "out"
    res = sgpipe("precompute", _env_config(tmp_path, "env.exr"), "--out", out)
    assert_bad_input(res, "env.exr", "NaN/Inf", "envmap.environment")
    assert not (out / "envmap").exists()


@pytest.mark.parametrize("shape,value,needle", [
    ((8, 16, 3), 3e38, "radiance above 1e+30 in 1 pixels"),   # wrote Inf into the pyramid
    ((2, 1000, 3), 1.0, "twice as wide as it is high"),
    ((16, 16, 3), 1.0, "twice as wide as it is high"),
])
def test_environment_out_of_range(tmp_path, shape, value, needle):
    img = np.ones(shape, np.float32)
    img[1, 1, 0] = value
    write_exr(tmp_path / "env.exr", img)
    out = tmp_path / "out"
    res = sgpipe("precompute", _env_config(tmp_path, "env.exr"), "--out", out)
    assert_bad_input(res, "env.exr", "envmap.environment", needle)
    assert not out.exists()


def test_wrong_channel_count_environment(tmp_path):
    write_exr(tmp_path / "env.exr", np.ones((8, 16, 2), np.float32))
    res = sgpipe("precompute", _env_config(tmp_path, "env.exr"), "--out", tmp_path / "out")
    assert_bad_input(res, "env.exr", "channels", "envmap.environment")


def test_unreadable_environment(tmp_path):
    (tmp_path / "env.exr").write_bytes(b"garbage")
    res = sgpipe("precompute", _env_config(tmp_path, "env.exr"), "--out", tmp_path / "out")
    assert_bad_input(res, "env.exr", "unreadable")


def test_missing_environment_file(tmp_path):
    res = sgpipe("precompute", _env_config(tmp_path, "nope.exr"), "--out", tmp_path / "out")
    assert_bad_input(res, "envmap.environment", "not found")


def test_unwritable_output(tmp_path):
    write_exr(tmp_path / "env.exr", np.ones((8, 16, 3), np.float32))
    blocker = tmp_path / "blocker"
    blocker.write_text("a file, not a folder")
    res = sgpipe("precompute", _env_config(tmp_path, "env.exr"), "--out", blocker / "out")
    assert_bad_input(res, "blocker", "--out", "not writable")


def test_empty_mesh(tmp_path):
    (tmp_path / "empty.obj").write_text("# no geometry\n")
    p = write(tmp_path, """
        scene:
          objects:
            - {name: thing, mesh: empty.obj}
        visibility: {trace_resolution: 16, resolution: 8, pca_terms: 2}
    """)
    out = tmp_path / "out"
    res = sgpipe("precompute", p, "--out", out)
    assert_bad_input(res, "empty.obj")
    assert not (out / "visibility").exists()


def test_bad_mesh_stops_run_before_any_stage_writes(tmp_path):
    """`sgpipe run` found a bad mesh only in the visibility stage, after fit and envmap had
    written their folders."""
    (tmp_path / "empty.obj").write_text("# no geometry\n")
    write_exr(tmp_path / "env.exr", np.ones((8, 16, 3), np.float32))
    p = write(tmp_path, """
        scene:
          objects:
            - {name: thing, mesh: empty.obj, material: m}
        fit:
          materials:
            - {name: m, model: lambert}
        envmap: {environment: env.exr, cube_resolution: 8}
        visibility: {trace_resolution: 16, resolution: 8, pca_terms: 2}
    """)
    out = tmp_path / "out"
    assert_bad_input(sgpipe("run", p, "--out", out), "empty.obj")
    assert not out.exists() or list(out.iterdir()) == []


def _spin(seconds: float) -> None:
    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end:
        pass


@pytest.fixture
def handlers(monkeypatch):
    """The CLI's signal handlers in this process; `cli.unraisable` lists what reached the
    unraisable hook ('Exception ignored ...' messages) underneath the CLI's."""
    from sgpipe import cli
    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    old = cli._install_signal_handlers()
    monkeypatch.setattr(cli, "unraisable", unraisable, raising=False)
    yield cli
    cli._restore_signal_handlers(old)


def test_swallowed_interruption_is_raised_again(handlers):
    """A library that catches BaseException (trimesh does around its imports) swallows the
    first signal's exception: it is raised again once no exception is being handled, but never
    while one is (cleanup in except / finally / __exit__ must not be cut short)."""
    cli = handlers
    try:
        os.kill(os.getpid(), signal.SIGINT)
        _spin(1.0)
        pytest.fail("the signal did not interrupt")
    except BaseException as e:    # the swallowing library
        assert isinstance(e, cli.Interrupted) and e.signum == signal.SIGINT
    try:
        raise RuntimeError("some cleanup under way")
    except RuntimeError:
        _spin(0.8)                 # three timer ticks: none raises here
    with pytest.raises(cli.Interrupted):
        _spin(2.0)


def test_interruption_in_a_c_callback_is_quiet(handlers):
    """An Interrupted raised inside a ctypes callback cannot propagate (CPython prints
    'Exception ignored ...'); the CLI stays quiet and raises it again afterwards."""
    cli = handlers
    cmp_t = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_int),
                             ctypes.POINTER(ctypes.c_int))

    def cmp(a, b):
        if not cli._received:
            os.kill(os.getpid(), signal.SIGINT)
            _spin(0.05)
        return a[0] - b[0]

    arr = (ctypes.c_int * 2)(2, 1)
    ctypes.CDLL(None).qsort(arr, 2, ctypes.sizeof(ctypes.c_int), cmp_t(cmp))
    with pytest.raises(cli.Interrupted):
        _spin(2.0)
    assert cli.unraisable == []


def test_empty_out_is_refused_not_the_current_folder(tmp_path):
    """`--out "$UNSET"` wrote the stage folders into the current folder."""
    p = write(tmp_path, "name: x\nfit:\n  materials:\n    - {name: m, model: lambert}\n")
    work = tmp_path / "cwd"
    work.mkdir()
    assert_bad_input(sgpipe("fit", p, "--out", "", cwd=work), "--out: is empty")
    for cmd in ("export", "report"):
        assert_bad_input(sgpipe(cmd, tmp_path, "--out", "", cwd=work), "--out: is empty")
    assert list(work.iterdir()) == []
    f = tmp_path / "file.txt"
    f.write_text("x")
    assert_bad_input(sgpipe("fit", p, "--out", f), "is a file, not a folder")


def test_users_own_folder_named_like_a_stage_is_kept(tmp_path):
    """OUT/fit holding the user's files (no manifest) was replaced, i.e. deleted, without a
    word; an sgpipe stage folder is still replaced as before."""
    p = write(tmp_path, "name: x\nfit:\n  materials:\n    - {name: m, model: lambert}\n")
    out = tmp_path / "out"
    (out / "fit").mkdir(parents=True)
    (out / "fit" / "notes.txt").write_text("mine")
    assert_bad_input(sgpipe("fit", p, "--out", out), f"{out / 'fit'}: --out:",
                     "not written by sgpipe")
    assert (out / "fit" / "notes.txt").read_text() == "mine"
    (out / "fit" / "notes.txt").unlink()
    assert sgpipe("fit", p, "--out", out).returncode == 0     # an empty folder is fine
    assert (out / "fit" / "manifest.json").is_file()
