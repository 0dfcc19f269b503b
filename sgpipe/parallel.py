"""The one executor interface heavy stages map their chunks through (docs/CONVENTIONS.md:
Parallel work).

Local processes by default, sized to the cores; results come back in input order so merged
artifacts are deterministic. Swapping in another backend (e.g. Dask) only touches this file.

Interruption: the parent owns the decision. Workers ignore SIGINT (a terminal's Ctrl-C reaches
the whole process group), and when anything interrupts the parent (a signal turned into an
exception, a failed chunk) the pending chunks are cancelled and the workers killed before the
exception goes on, so the caller's cleanup runs at once instead of after the queued work.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.context import SpawnContext, SpawnProcess
from typing import Any, Callable, Iterable, Sequence

import click

_KILL_GRACE_S = 0.5   # SIGTERM → SIGKILL for a worker stuck in native code


def default_workers() -> int:
    """Workers to use when none is configured: the cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


def _progress(total: int, desc: str):
    show = sys.stderr.isatty() or os.environ.get("SGPIPE_PROGRESS") == "1"
    return click.progressbar(length=total, label=desc, file=sys.stderr,
                             show_pos=True, show_eta=True) if show and total > 1 else None


@contextlib.contextmanager
def _sigint_ignored():
    """SIGINT ignored while a worker is created: an ignored signal stays ignored across exec,
    so the worker never sees Ctrl-C, not even while it imports (a handler would not carry)."""
    import threading
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


class _WorkerProcess(SpawnProcess):
    def start(self):
        with _sigint_ignored():
            super().start()


class _WorkerContext(SpawnContext):
    # spawn: forked children would inherit numba/OpenCL thread pools in unknown states.
    Process = _WorkerProcess


def _worker_init() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _stop_pool(ex: ProcessPoolExecutor) -> None:
    """Drop the queued chunks, kill the workers (their chunks are lost anyway) and return once
    they are gone; shutdown(wait=True) would instead wait for every queued chunk. (Futures are
    not cancelled here: the executor's own thread cancels them, and it fails on futures
    cancelled behind its back when it finds the pool broken.)"""
    procs = list((ex._processes or {}).values())
    ex.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    for p in procs:
        p.join(_KILL_GRACE_S)
        if p.is_alive():
            with contextlib.suppress(Exception):
                p.kill()
            p.join(_KILL_GRACE_S)


def map_chunks(fn: Callable[[Any], Any], items: Sequence[Any] | Iterable[Any], *,
               workers: int | None = None, desc: str = "working") -> list[Any]:
    """Apply `fn` (a module-level function) to every item; return results in input order.

    workers=None or 0 uses every core; workers=1 runs in this process (no pickling), which is
    also what happens for a single item. Any exception (KeyboardInterrupt and signals turned
    into exceptions included) stops the pool's workers before it propagates.
    """
    items = list(items)
    n = default_workers() if not workers else int(workers)
    n = max(1, min(n, len(items)))
    bar = _progress(len(items), desc)
    results: list[Any] = []
    try:
        if n == 1:
            for it in items:
                results.append(fn(it))
                if bar:
                    bar.update(1)
        else:
            ex = ProcessPoolExecutor(max_workers=n, mp_context=_WorkerContext(),
                                     initializer=_worker_init)
            try:
                futures = [ex.submit(fn, it) for it in items]
                for f in futures:
                    results.append(f.result())
                    if bar:
                        bar.update(1)
            except BaseException:
                _stop_pool(ex)
                raise
            ex.shutdown(wait=True)
    finally:
        if bar:
            bar.render_finish()
    return results


def chunk_ranges(n: int, chunk: int) -> list[tuple[int, int]]:
    """Split range(n) into [start, stop) pieces of at most `chunk` items."""
    chunk = max(1, int(chunk))
    return [(s, min(n, s + chunk)) for s in range(0, n, chunk)]
