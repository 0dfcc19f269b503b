"""The one executor interface heavy stages map their chunks through (GUIDE: Parallel work).

Local processes by default, sized to the cores; results come back in input order so merged
artifacts are deterministic. Swapping in another backend (e.g. Dask) only touches this file.
"""

from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from typing import Any, Callable, Iterable, Sequence

import click


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


def map_chunks(fn: Callable[[Any], Any], items: Sequence[Any] | Iterable[Any], *,
               workers: int | None = None, desc: str = "working") -> list[Any]:
    """Apply `fn` (a module-level function) to every item; return results in input order.

    workers=None or 0 uses every core; workers=1 runs in this process (no pickling), which is
    also what happens for a single item.
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
            # spawn: forked children would inherit numba/OpenCL thread pools in unknown states.
            with ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn")) as ex:
                for r in ex.map(fn, items):
                    results.append(r)
                    if bar:
                        bar.update(1)
    finally:
        if bar:
            bar.render_finish()
    return results


def chunk_ranges(n: int, chunk: int) -> list[tuple[int, int]]:
    """Split range(n) into [start, stop) pieces of at most `chunk` items."""
    chunk = max(1, int(chunk))
    return [(s, min(n, s + chunk)) for s in range(0, n, chunk)]
