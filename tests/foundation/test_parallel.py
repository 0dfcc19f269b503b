"""The executor keeps input order and gives the same result for any worker count; workers
ignore SIGINT, and a failure or an interruption stops them at once."""

import _thread
import multiprocessing
import signal
import threading
import time
from pathlib import Path

import pytest

from sgpipe.parallel import chunk_ranges, map_chunks


def _square_sum(r):
    a, b = r
    return sum(i * i for i in range(a, b))


def test_map_chunks_order_and_worker_independence():
    chunks = chunk_ranges(1000, 37)
    assert chunks[0] == (0, 37) and chunks[-1] == (999, 1000) and len(chunks) == 28
    serial = map_chunks(_square_sum, chunks, workers=1)
    pooled = map_chunks(_square_sum, chunks, workers=2)
    assert serial == pooled
    assert sum(serial) == sum(i * i for i in range(1000))


def _slow(i):
    time.sleep(0.3)
    if i == 3:
        raise ValueError("chunk 3 failed")
    return i


def _sigint_ignored(_):
    return signal.getsignal(signal.SIGINT) is signal.SIG_IGN


def _running_workers() -> list[int]:
    """Child processes still running (not zombies). By /proc rather than Process.exitcode: the
    executor's own thread may reap a killed worker, leaving its Process object without one."""
    alive = []
    for p in multiprocessing.active_children():
        try:
            state = Path(f"/proc/{p.pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            alive.append(p.pid)
    return alive


def test_workers_ignore_sigint():
    """A terminal's Ctrl-C reaches the whole process group: the parent decides, not them."""
    assert map_chunks(_sigint_ignored, range(4), workers=2) == [True] * 4


def test_failure_stops_the_pool_at_once():
    """A failing chunk (or an interruption) cancels the queued chunks and kills the workers
    instead of waiting for all 200 × 0.3 s / 2 of them."""
    t0 = time.monotonic()
    with pytest.raises(ValueError, match="chunk 3"):
        map_chunks(_slow, range(200), workers=2)
    assert time.monotonic() - t0 < 10
    assert _running_workers() == []


def test_interrupt_stops_the_pool_at_once():
    timer = threading.Timer(3.0, _thread.interrupt_main)   # KeyboardInterrupt in this thread
    timer.start()
    t0 = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            map_chunks(_slow, range(4, 400), workers=2)
    finally:
        timer.cancel()
    assert time.monotonic() - t0 < 6
    assert _running_workers() == []


def test_scheduler_without_the_dask_extra_is_bad_input_naming_the_extra():
    """Where `distributed` is not installed (blocked here by a None in sys.modules, which
    makes its import fail the same way), a scheduler address is one BadInput line."""
    import subprocess
    import sys
    code = ("import sys; sys.modules['distributed'] = None\n"
            "from sgpipe.errors import BadInput\n"
            "from sgpipe.parallel import map_chunks\n"
            "try:\n"
            "    map_chunks(abs, [1, -2], scheduler='tcp://127.0.0.1:8786')\n"
            "except BadInput as e:\n"
            "    print(e.one_line())\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().startswith("--scheduler: ")
    assert "pip install -e '.[dask]'" in r.stdout


def test_no_scheduler_means_the_local_pool():
    from sgpipe.parallel import cluster, on_cluster
    with cluster(None) as c:
        assert c is None and not on_cluster()
        assert map_chunks(_square_sum, chunk_ranges(10, 3), workers=1) == [5, 50, 149, 81]
