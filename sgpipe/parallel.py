"""The one executor interface heavy stages map their chunks through (docs/CONVENTIONS.md:
Parallel work).

Local processes by default, sized to the cores; results come back in input order so merged
artifacts are deterministic. Inside `cluster(address)` (the CLI's `--scheduler`), chunks run as
futures on a Dask cluster instead: the same chunks, gathered in the same order, so the artifacts
are the same bytes. This is the only module that imports Dask (`distributed`, lazily).

Interruption: the parent owns the decision. Workers ignore SIGINT (a terminal's Ctrl-C reaches
the whole process group), and when anything interrupts the parent (a signal turned into an
exception, a failed chunk) the pending chunks are cancelled and the workers killed before the
exception goes on, so the caller's cleanup runs at once instead of after the queued work. A
parent killed outright (SIGKILL, no handler) takes its workers with it: each asks the kernel for
SIGKILL when its parent dies (Linux PR_SET_PDEATHSIG). On a Dask cluster a chunk whose client is
gone stops within a fraction of a second (`_CancelWatch`) instead of running to its end.
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

from sgpipe.errors import BadInput

_KILL_GRACE_S = 0.5   # SIGTERM → SIGKILL for a worker stuck in native code
_CONNECT_TIMEOUT_S = 5.0
_CLOSE_TIMEOUT_S = 5.0
# A chunk that raised is run again this often (a worker that dies mid-chunk is handled by the
# scheduler itself: its chunks go to other workers, up to distributed.scheduler.allowed-failures).
_CHUNK_RETRIES = 2
DASK_EXTRA_HINT = "install the [dask] extra: pip install -e '.[dask]'"

_clients: list = []   # the distributed.Client of each open `cluster()` block, innermost last


def default_workers() -> int:
    """Workers to use when none is configured: the cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


def progress(total: int, desc: str):
    """The click progress bar the chunk maps show (on a terminal, or SGPIPE_PROGRESS=1), or
    None; `update(n)` it as work completes, `render_finish()` at the end."""
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


_PR_SET_PDEATHSIG = 1   # linux/prctl.h


def _worker_init(parent: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent(parent)


def _die_with_parent(parent: int) -> None:
    """Have the kernel SIGKILL this worker when the process that started it dies (a SIGKILL of
    `sgpipe` runs no handler, and the executor's workers would otherwise live on under PID 1,
    holding their memory and the resource tracker). Linux only; elsewhere a no-op. The signal
    follows the thread that started the worker: map_chunks starts (through submit) and waits
    for its pool in one thread."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - no prctl in this libc
        return
    if os.getppid() != parent:
        # the parent died before prctl took effect: nothing would signal us any more
        os._exit(1)


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
               workers: int | None = None, desc: str = "working",
               scheduler: str | None = None) -> list[Any]:
    """Apply `fn` (a module-level function) to every item; return results in input order.

    On a Dask cluster when `scheduler` (an address) is given or a `cluster()` block is open;
    `workers` then does not apply (the cluster's workers run the chunks). Otherwise local:
    workers=None or 0 uses every core; workers=1 runs in this process (no pickling), which is
    also what happens for a single item. Any exception (KeyboardInterrupt and signals turned
    into exceptions included) stops the pool's workers / cancels the futures before it
    propagates.
    """
    items = list(items)
    if scheduler:
        with cluster(scheduler):
            return map_chunks(fn, items, desc=desc)
    n = default_workers() if not workers else int(workers)
    n = max(1, min(n, len(items)))
    bar = progress(len(items), desc)
    results: list[Any] = []
    try:
        if _clients and items:
            results = _map_on_cluster(_clients[-1], fn, items, bar)
        elif n == 1:
            for it in items:
                results.append(fn(it))
                if bar:
                    bar.update(1)
        else:
            ex = ProcessPoolExecutor(max_workers=n, mp_context=_WorkerContext(),
                                     initializer=_worker_init, initargs=(os.getpid(),))
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


# -- Dask ---------------------------------------------------------------------------------------

def on_cluster() -> bool:
    """True inside a `cluster()` block: chunks may run on other machines, so they must carry
    their data (or name files on a filesystem every worker sees), not point into local /tmp."""
    return bool(_clients)


@contextlib.contextmanager
def cluster(address: str | None, *, file: str | None = None, key: str = "--scheduler"):
    """Run every `map_chunks` inside the block on the Dask scheduler at `address` (None or "":
    the local pool). Connects once, up front: a missing `distributed` package or an unreachable
    address is a BadInput naming `file`/`key` (where the address came from). The client is
    closed when the block ends, however it ends."""
    if not address:
        yield None
        return
    client = _connect(str(address), file, key)
    _clients.append(client)
    try:
        yield client
    finally:
        _clients.remove(client)
        with contextlib.suppress(Exception):
            client.close(timeout=_CLOSE_TIMEOUT_S)


def _connect(address: str, file: str | None, key: str):
    try:
        import distributed
    except ImportError:
        raise BadInput(f"a Dask scheduler ({address}) needs the `distributed` package: "
                       f"{DASK_EXTRA_HINT}", file=file, key=key) from None
    try:
        # a malformed address fails here, before a Client exists (its __del__ would hang 10 s)
        distributed.comm.get_address_host_port(address)
    except Exception as e:
        raise BadInput(f"{address!r} is not a Dask scheduler address (tcp://HOST:PORT): "
                       f"{' '.join(str(e).split())[:160]}", file=file, key=key) from None
    try:
        return distributed.Client(address, timeout=_CONNECT_TIMEOUT_S, set_as_default=False)
    except Exception as e:      # OSError / TimeoutError
        why = " ".join(str(e).split()) or type(e).__name__
        raise BadInput(f"cannot reach the Dask scheduler at {address!r} within "
                       f"{_CONNECT_TIMEOUT_S:g} s ({why[:160]})", file=file, key=key) from None


class _Chunk:
    """An item shipped to a Dask worker as one opaque object: Dask looks inside tuples, lists,
    dicts and dataclasses for tasks and futures, which a chunk's own data must not be taken for."""

    __slots__ = ("item",)

    def __init__(self, item):
        self.item = item


class ChunkCancelled(BaseException):
    """Raised inside a chunk running on a Dask worker whose task nobody wants any more (its
    client is gone, or it cancelled the run): the chunk stops at its next Python step."""


#: how often a running chunk's watcher asks the worker whether its task is still wanted
_CANCEL_POLL_S = 0.25
_RUNNING = ("executing", "long-running")


class _CancelWatch:
    """A thread that raises ChunkCancelled in the chunk's thread once the worker no longer
    runs the chunk's task for anyone (the scheduler released it: the client disconnected or
    cancelled). Dask itself lets a released task run to its end. The exception is delivered
    at the chunk's next Python bytecode (between native calls); `stop` withdraws one that was
    scheduled but not yet delivered, so it never lands in the worker's own code."""

    def __init__(self):
        import ctypes
        import threading
        self._set_exc = ctypes.pythonapi.PyThreadState_SetAsyncExc
        self._tid = ctypes.c_ulong(threading.get_ident())
        self._lock = threading.Lock()
        self._done = threading.Event()
        self._fired = False
        try:
            from distributed import get_worker
            worker = get_worker()
            key = worker.get_current_task()
        except Exception:  # noqa: BLE001 - not on a worker: nothing to watch
            self._done.set()
            return
        self._thread = threading.Thread(target=self._watch, args=(worker, key), daemon=True,
                                        name="sgpipe-cancel-watch")
        self._thread.start()

    def _watch(self, worker, key) -> None:
        import ctypes
        while not self._done.wait(_CANCEL_POLL_S):
            ts = worker.state.tasks.get(key)
            if ts is not None and ts.state in _RUNNING:
                continue
            with self._lock:
                if not self._done.is_set():
                    self._fired = True
                    self._set_exc(self._tid, ctypes.py_object(ChunkCancelled))
            return

    def stop(self) -> None:
        with self._lock:
            self._done.set()
            if self._fired:
                self._set_exc(self._tid, None)   # withdraw it if not yet delivered


def _run_chunk(fn: Callable[[Any], Any], chunk: _Chunk) -> Any:
    watch = _CancelWatch()
    try:
        return fn(chunk.item)
    finally:
        watch.stop()


def _map_on_cluster(client, fn: Callable[[Any], Any], items: list, bar) -> list[Any]:
    """Submit every item as a future (explicit keys: one run's chunks never merge with another
    run's, even for equal inputs), gather in input order, cancel what is left on any exception."""
    import uuid
    token = uuid.uuid4().hex[:12]
    name = getattr(fn, "__name__", "chunk")
    keys = [f"{name}-{token}-{i}" for i in range(len(items))]   # dashboard groups by name
    futures = client.map(_run_chunk, [fn] * len(items), [_Chunk(it) for it in items], key=keys,
                         retries=_CHUNK_RETRIES)
    results = []
    try:
        for f in futures:
            results.append(f.result())
            f.release()
            if bar:
                bar.update(1)
    except BaseException:
        with contextlib.suppress(Exception):
            client.cancel(futures)
        raise
    return results
