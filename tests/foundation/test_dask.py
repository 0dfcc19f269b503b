"""The Dask backend against a real cluster: a `dask scheduler` and two single-threaded `dask
worker`s on 127.0.0.1, the visibility stage through the CLI with --scheduler / $SGPIPE_SCHEDULER
/ `scheduler:`, byte-compared with the local process pool; a worker killed mid-stage; bad and
unreachable addresses (issue #18)."""

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed", reason="the [dask] extra (make test installs it)")

SAMPLES = Path(__file__).resolve().parents[2] / "data_samples"
DASK = Path(sys.executable).parent / "dask"
# a sphere on a floor: 10363 vertices, 16² rays each (~2 s on two local processes)
CONFIG = f"""name: dasktiny
seed: 3
workers: 2
scene:
  objects:
    - {{name: ball, sphere_radius: 0.5, translate: [0, 0.5, 0]}}
    - {{name: floor, mesh: {SAMPLES / 'floor.obj'}, scale: 0.4}}
visibility: {{trace_resolution: 16, resolution: 8, pca_terms: 4, sphere_subdivisions: 2,
             chunk_vertices: 64}}
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        p.terminate()
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """(address, worker processes, scheduler log path), stopped when the module ends."""
    logs = tmp_path_factory.mktemp("dask")
    addr = f"tcp://127.0.0.1:{_free_port()}"
    procs = []

    def start(args, log):
        procs.append(subprocess.Popen([str(DASK), *args], stdout=subprocess.DEVNULL,
                                      stderr=open(logs / log, "wb"), cwd=logs))
        return procs[-1]
    try:
        start(["scheduler", "--host", "127.0.0.1", "--port", addr.rsplit(":", 1)[1],
               "--no-dashboard"], "scheduler.log")
        # --no-nanny: a killed worker stays dead (a nanny would restart it)
        workers = [start(["worker", addr, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                          "--host", "127.0.0.1"], f"worker{i}.log") for i in range(2)]
        deadline = time.monotonic() + 60
        while True:
            try:
                with distributed.Client(addr, timeout=5) as c:
                    c.wait_for_workers(2, timeout=max(1, deadline - time.monotonic()))
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
        yield addr, workers, logs / "scheduler.log"
    finally:
        for p in reversed(procs):
            _stop(p)


def _sgpipe(*args, env=None, **kw):
    full = {k: v for k, v in os.environ.items() if k != "SGPIPE_SCHEDULER"}
    full.update(env or {})
    kw = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, **kw}
    return subprocess.Popen([sys.executable, "-m", "sgpipe", *map(str, args)], env=full,
                            text=True, **kw)


def _run(*args, env=None):
    p = _sgpipe(*args, env=env)
    out, err = p.communicate(timeout=300)
    return p.returncode, out, err


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name != "timings.json"}


def _compute_s(addr: str, prefix: str = "trace_chunk") -> float:
    """Seconds the cluster has spent computing tasks named `prefix` so far."""
    with distributed.Client(addr, timeout=5) as c:
        return c.run_on_scheduler(lambda dask_scheduler: dask_scheduler.task_prefixes[prefix]
                                  .all_durations.get("compute", 0.0)
                                  if prefix in dask_scheduler.task_prefixes else 0.0)


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    d = tmp_path_factory.mktemp("cfg")
    (d / "vis.yaml").write_text(CONFIG)
    (d / "vis_cfg_sched.yaml").write_text(CONFIG + "scheduler: not-an-address\n")
    return d


def _local(config, tmp: Path, *extra) -> dict[str, bytes]:
    rc, _, err = _run("precompute", config / "vis.yaml", "--out", tmp, *extra)
    assert rc == 0, err
    return _files(tmp)


def test_cluster_run_is_byte_identical_and_cli_beats_env_beats_config(cluster, config, tmp_path):
    addr, _, _ = cluster
    local = _local(config, tmp_path / "local")
    assert any(k.startswith("visibility/") and k.endswith(".npz") for k in local)
    before = _compute_s(addr)
    # env beats the config's (malformed) `scheduler:`
    rc, _, err = _run("precompute", config / "vis_cfg_sched.yaml", "--out", tmp_path / "env",
                      env={"SGPIPE_SCHEDULER": addr})
    assert rc == 0, err
    middle = _compute_s(addr)
    assert middle > before, "the chunks did not run on the cluster"
    # --scheduler beats both
    rc, _, err = _run("precompute", config / "vis_cfg_sched.yaml", "--out", tmp_path / "cli",
                      "--scheduler", addr, env={"SGPIPE_SCHEDULER": "tcp://127.0.0.1:1"})
    assert rc == 0, err
    assert _compute_s(addr) > middle
    # the same bytes, config.resolved.yaml and manifest.json included (the address is not kept)
    assert _files(tmp_path / "env") == local
    assert _files(tmp_path / "cli") == local


def test_config_scheduler_is_used_and_a_bad_one_is_one_line(config, tmp_path):
    rc, _, err = _run("precompute", config / "vis_cfg_sched.yaml", "--out", tmp_path / "o")
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "vis_cfg_sched.yaml: scheduler:" in lines[0] and "tcp://HOST:PORT" in lines[0]
    assert not (tmp_path / "o").exists()


def test_unreachable_scheduler_is_one_line_exit_2_nothing_written(config, tmp_path):
    dead = f"tcp://127.0.0.1:{_free_port()}"
    t0 = time.monotonic()
    rc, _, err = _run("precompute", config / "vis.yaml", "--out", tmp_path / "o",
                      "--scheduler", dead)
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sgpipe: error: --scheduler:"), err
    assert dead in lines[0] and "cannot reach" in lines[0]
    assert time.monotonic() - t0 < 30
    assert not (tmp_path / "o").exists()


def test_a_worker_killed_mid_stage_is_retried_and_output_identical(cluster, config, tmp_path):
    """Many small chunks (8 vertices: ~1300 futures, several seconds) so the kill lands while
    both workers are busy; the scheduler moves the dead worker's chunks to the other one."""
    addr, workers, sched_log = cluster
    small = ("--set", "visibility.chunk_vertices=8")
    local = _local(config, tmp_path / "local", *small)
    p = _sgpipe("precompute", config / "vis.yaml", "--out", tmp_path / "dask", *small,
                "--scheduler", addr)
    err_lines: list[str] = []
    started = threading.Event()

    def read():
        for line in p.stderr:
            err_lines.append(line)
            if "rays per vertex" in line:       # logged right before the chunks are submitted
                started.set()
    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    assert started.wait(120), "".join(err_lines)
    time.sleep(1.0)
    assert p.poll() is None, "the stage ended before the kill: make it longer"
    workers[1].send_signal(signal.SIGKILL)
    workers[1].wait()
    p.wait(300)
    reader.join(10)
    assert p.returncode == 0, "".join(err_lines)
    # the scheduler saw the worker go (its chunks, queued or finished, were recomputed)
    assert "Remove worker" in sched_log.read_text()
    assert _files(tmp_path / "dask") == local


def _running(addr: str, prefix: str = "trace_chunk") -> list[str]:
    """Keys of `prefix` tasks that a worker thread is still running (wanted or released)."""
    def keys(dask_worker):
        return [str(k) for k, ts in dask_worker.state.tasks.items()
                if prefix in str(k) and ts.state in ("executing", "long-running", "cancelled")]
    with distributed.Client(addr, timeout=5) as c:
        return sum(c.run(keys).values(), [])


def test_a_chunk_stops_when_its_client_is_killed(cluster, config, tmp_path):
    """Long chunks (8192 vertices × 128² rays, ~9 s each on a single-threaded worker); the
    client (`sgpipe precompute`) is SIGKILLed a second into one: the worker drops it within
    3 s (measured 0.28 s). Dask alone releases the task but lets its thread run to the chunk's
    end (measured 8.0 s after the kill)."""
    addr = cluster[0]
    long = ("--set", "visibility.trace_resolution=128", "--set", "visibility.resolution=16",
            "--set", "visibility.chunk_vertices=8192")
    p = _sgpipe("precompute", config / "vis.yaml", "--out", tmp_path / "out", *long,
                "--scheduler", addr, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not _running(addr):
            assert p.poll() is None and time.monotonic() < deadline, "no chunk ever ran"
            time.sleep(0.1)
        time.sleep(1.0)
        p.kill()
        p.wait(10)
        t0 = time.monotonic()
        while _running(addr) and time.monotonic() - t0 < 60:
            time.sleep(0.1)
        stopped_s = time.monotonic() - t0
    finally:
        _stop(p)
    print(f"stopped {stopped_s:.2f} s after the kill")
    assert stopped_s < 3.0, f"the orphaned chunk ran on for {stopped_s:.1f} s"


def test_only_the_executor_imports_dask():
    """Algorithm code never imports Dask: by source (no import statement outside parallel.py)
    and by behaviour (importing every package and stage leaves dask out of sys.modules)."""
    import re
    root = Path(__file__).resolve().parents[2] / "sgpipe"
    pattern = re.compile(r"^\s*(import|from)\s+(dask|distributed)\b", re.M)
    offenders = [p.relative_to(root).as_posix() for p in root.rglob("*.py")
                 if p.name != "parallel.py" and pattern.search(p.read_text())]
    assert offenders == []
    code = ("import importlib, pkgutil, sys, sgpipe\n"
            "for m in pkgutil.walk_packages(sgpipe.__path__, 'sgpipe.'):\n"
            "    if not m.name.endswith('__main__'):\n"
            "        importlib.import_module(m.name)\n"
            "print(sorted(k for k in sys.modules if k.split('.')[0] in ('dask', 'distributed')))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]", r.stdout


def test_reference_tiles_on_the_cluster_are_byte_identical(cluster, tmp_path):
    """The Monte Carlo reference's pixel tiles carry their scene to remote workers (no file in
    this machine's /tmp) and give the local run's bytes."""
    from tiny_scene import tiny_config  # tests/ is on sys.path
    addr, _, _ = cluster
    cfg = tmp_path / "ref.yaml"
    cfg.write_text(tiny_config("[sg, reference]", workers=2))  # several tiles at once
    rc, _, err = _run("run", cfg, "--out", tmp_path / "local")
    assert rc == 0, err
    before = _compute_s(addr, "shade_tile")
    rc, _, err = _run("run", cfg, "--out", tmp_path / "dask", "--scheduler", addr)
    assert rc == 0, err
    assert _compute_s(addr, "shade_tile") > before, "the tiles did not run on the cluster"
    assert _files(tmp_path / "dask") == _files(tmp_path / "local")
