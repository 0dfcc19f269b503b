"""SIGINT / SIGTERM through a real `sgpipe` subprocess, mid-stage: the run ends within 2 s with
exit status 130 / 143 and one line, its pool workers with it; no staging or temp folder is left
and the stages finished before it are intact."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from sgpipe.io import file_hash
from sgpipe.stages.base import folder_lock

SAMPLES = Path(__file__).resolve().parents[2] / "data_samples"
SCENE = f"""
scene:
  objects:
    - {{name: ball, sphere_radius: 0.5, translate: [0, 0.5, 0], material: shiny}}
    - {{name: floor, mesh: {SAMPLES / 'floor.obj'}, scale: 0.4, material: matte}}
envmap: {{environment: {SAMPLES / 'studio.exr'}, cube_resolution: 16}}
"""
FIT = """
fit:
  materials:
    - {name: shiny, model: ward, params: {alpha: 0.15, kd: [0.2, 0.1, 0.05], ks: 0.6}}
    - {name: matte, model: lambert, params: {kd: [0.5, 0.5, 0.5]}}
  ndf_sg: {report_lobes: 0}
  view_gmm: {lobes: 4, samples: 256, theta_count: 4, report_lobes: 0}
"""
LIMIT_S = 2.0


def write(tmp_path, text: str) -> Path:
    p = tmp_path / "c.yaml"
    p.write_text(textwrap.dedent(text))
    return p


def start(tmp_path, *args, env=None) -> tuple[subprocess.Popen, Path]:
    """`python -m sgpipe ARGS` in a session of its own (so a signal can go to its group, as a
    terminal's Ctrl-C does); stderr into a file that the test can read while it runs; `env`:
    extra environment variables."""
    err = tmp_path / f"stderr{time.monotonic_ns()}.txt"
    with open(err, "w") as fh:
        proc = subprocess.Popen([sys.executable, "-m", "sgpipe", *map(str, args)],
                                stdout=subprocess.DEVNULL, stderr=fh, start_new_session=True,
                                env={**os.environ, **(env or {})})
    return proc, err


def wait_for(proc, what: str, cond, timeout: float = 120.0) -> None:
    t_end = time.monotonic() + timeout
    while not cond():
        assert proc.poll() is None, f"sgpipe ended (rc {proc.returncode}) before {what}"
        assert time.monotonic() < t_end, f"no {what} after {timeout} s"
        time.sleep(0.02)


def workers(sid: int) -> list[int]:
    """Live (not zombie) pool workers in the session `sid`."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
            cmd = (d / "cmdline").read_bytes()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[3]) == sid and fields[0] != "Z" and b"spawn_main" in cmd:
            found.append(int(d.name))
    return found


def interrupt(proc, sig: int, group: bool) -> tuple[int, float]:
    t0 = time.monotonic()
    (os.killpg if group else os.kill)(proc.pid, sig)
    try:
        rc = proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        pytest.fail("sgpipe did not end within 30 s of the signal")
    return rc, time.monotonic() - t0


def assert_interrupted(rc, seconds, err: Path, sig: int) -> None:
    text = err.read_text()
    assert rc == 128 + sig, text
    assert seconds < LIMIT_S, f"ended {seconds:.2f} s after the signal"
    lines = [ln for ln in text.splitlines()
             if ln.startswith("sgpipe:") and not ln.startswith("sgpipe: waiting")]
    assert lines == [f"sgpipe: interrupted ({signal.Signals(sig).name}); finished stages are "
                     "kept"], text
    assert "Traceback" not in text and "Exception ignored" not in text, text


def assert_intact(stage_dir: Path) -> None:
    man = json.loads((stage_dir / "manifest.json").read_text())
    assert man["outputs"]
    for name, digest in man["outputs"].items():
        assert file_hash(stage_dir / name) == digest, name


@pytest.mark.parametrize("sig,group", [(signal.SIGINT, True), (signal.SIGTERM, False)],
                         ids=["ctrl-c-to-group", "sigterm-to-parent"])
def test_pool_stage(tmp_path, sig, group):
    """Visibility traces in a process pool: signalled while the workers trace (a terminal's
    Ctrl-C reaches them too; SIGTERM only the parent, which must stop them)."""
    # long chunks: waiting for the running ones (what a plain executor shutdown does) is slow
    cfg = write(tmp_path, SCENE + "visibility: {trace_resolution: 256, resolution: 8, "
                "pca_terms: 4, sphere_subdivisions: 2, chunk_vertices: 4096}\nworkers: 2\n")
    out = tmp_path / "out"
    proc, err = start(tmp_path, "precompute", cfg, "--out", out)
    wait_for(proc, "two tracing workers", lambda: (out / ".visibility.tmp").is_dir()
             and len(workers(proc.pid)) == 2)
    time.sleep(0.5)
    rc, seconds = interrupt(proc, sig, group)
    assert_interrupted(rc, seconds, err, sig)
    assert workers(proc.pid) == []
    assert sorted(p.name for p in out.iterdir()) == ["envmap"]
    assert_intact(out / "envmap")


def _session_processes(sid: int, marker: bytes) -> list[int]:
    """Live processes of the session `sid` whose command line holds `marker`."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            cmd = (d / "cmdline").read_bytes()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z" and marker in cmd:
            found.append(int(d.name))
    return found


def test_killed_parent_takes_its_workers_with_it(tmp_path):
    """SIGKILL of `sgpipe` alone (no handler runs) while two pool workers trace: the workers
    and multiprocessing's resource tracker end within seconds instead of living on under
    PID 1."""
    cfg = write(tmp_path, SCENE + "visibility: {trace_resolution: 256, resolution: 8, "
                "pca_terms: 4, sphere_subdivisions: 2, chunk_vertices: 4096}\nworkers: 2\n")
    out = tmp_path / "out"
    proc, err = start(tmp_path, "precompute", cfg, "--out", out)
    try:
        wait_for(proc, "two tracing workers", lambda: (out / ".visibility.tmp").is_dir()
                 and len(workers(proc.pid)) == 2)
        time.sleep(0.5)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        t_end = time.monotonic() + 10.0
        while (workers(proc.pid) or _session_processes(proc.pid, b"resource_tracker")) \
                and time.monotonic() < t_end:
            time.sleep(0.05)
        assert workers(proc.pid) == [], "pool workers outlived their killed parent"
        assert _session_processes(proc.pid, b"resource_tracker") == []
    finally:
        for pid in _session_processes(proc.pid, b""):
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)


def test_main_process_stage(tmp_path):
    """The fit stage computes in this process (numba kernels): Ctrl-C while it fits."""
    cfg = write(tmp_path, FIT.replace("samples: 256, theta_count: 4",
                                      "samples: 65536, theta_count: 32"))
    out = tmp_path / "out"
    proc, err = start(tmp_path, "fit", cfg, "--out", out)
    wait_for(proc, "fit staging folder", lambda: (out / ".fit.staging").is_dir())
    time.sleep(0.5)
    rc, seconds = interrupt(proc, signal.SIGINT, True)
    assert_interrupted(rc, seconds, err, signal.SIGINT)
    assert not out.exists()          # nothing finished: the folder the run made is gone


def test_render_stage(tmp_path):
    """Render: OpenCL shading, then the Monte Carlo reference in this process (workers: 1);
    SIGTERM during the reference leaves fit / envmap / visibility as they were."""
    cfg = write(tmp_path, SCENE + FIT + textwrap.dedent("""
        visibility: {trace_resolution: 16, resolution: 8, pca_terms: 4, sphere_subdivisions: 2}
        workers: 1
        render:
          camera: {eye: [0, 1.2, 3], target: [0, 0.4, 0], fov_deg: 40, width: 64, height: 48}
          methods: [sg, reference]
          lights: [{type: point, position: [1, 3, 1], intensity: [5, 5, 5], radius: 0.1}]
          spp: 4096
    """))
    out = tmp_path / "out"
    # the reference's progress bar (forced on without a terminal) says when it has started:
    # the signal then lands in the Monte Carlo work, not in an OpenCL build (a C call that
    # finishes before Python sees the signal)
    proc, err = start(tmp_path, "run", cfg, "--out", out, env={"SGPIPE_PROGRESS": "1"})
    wait_for(proc, "render staging folder", lambda: (out / ".render.staging").is_dir())
    wait_for(proc, "the reference's progress bar", lambda: "reference" in err.read_text())
    time.sleep(0.5)
    rc, seconds = interrupt(proc, signal.SIGTERM, False)
    assert_interrupted(rc, seconds, err, signal.SIGTERM)
    assert sorted(p.name for p in out.iterdir()) == ["envmap", "fit", "visibility"]
    for stage in ("envmap", "fit", "visibility"):
        assert_intact(out / stage)


def test_run_waiting_for_the_folder_lock(tmp_path):
    """A run waiting for another run's lock on its output folder says so and can be
    interrupted while it waits."""
    cfg = write(tmp_path, SCENE)
    out = tmp_path / "out"
    out.mkdir()
    with folder_lock(out):               # the "other run"
        proc, err = start(tmp_path, "precompute", cfg, "--out", out)
        wait_for(proc, "waiting line", lambda: "waiting for another sgpipe run" in
                 err.read_text())
        rc, seconds = interrupt(proc, signal.SIGINT, True)
    assert_interrupted(rc, seconds, err, signal.SIGINT)
    assert list(out.iterdir()) == []
