"""Write the report folder: `index.html`, the run's PNGs copied under `assets/<stage>/`, the
charts under `assets/plots/`. Everything goes into a staging folder beside the target that
replaces it only when complete: a bad input or a failure leaves nothing half-written, and a
previous report stays as it was."""

from __future__ import annotations

import contextlib
import os
import shutil
from pathlib import Path

from sgpipe.errors import BadInput
from sgpipe.io.atomic import atomic_folder
from sgpipe.report.collect import Run, check_run_dir, collect

INDEX = "index.html"
MARKER = ".sgpipe-report"        # marks a folder this command wrote (safe to replace)


def default_out(run_dir: Path) -> Path:
    return Path(run_dir) / "report"


def pictures(run: Run) -> list:
    """Every run PNG the page shows."""
    pics = [p for r in run.methods + ([run.truth] if run.truth else [])
            for p in (r.image, r.diff) if p is not None]
    pics += [p for m in run.materials for p in m.pictures]
    pics += run.envmap_previews
    pics += [p for ps in run.visibility_pictures.values() for p in ps]
    return pics


def _check_target(out_dir: Path) -> None:
    """The target may be absent, an empty folder or an earlier report; anything else is the
    user's and is not replaced."""
    if out_dir.exists() and not out_dir.is_dir():
        raise BadInput("exists and is not a folder", file=out_dir, key="--out")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not (out_dir / MARKER).is_file():
        raise BadInput("folder exists and is not an sgpipe report (it would be replaced); "
                       "choose another --out", file=out_dir, key="--out")


@contextlib.contextmanager
def _run_lock(run_dir: Path):
    """The run folder's lock (sgpipe.stages.base.folder_lock), so the page never catches a stage
    half-way through replacing its folder: a running `sgpipe run` is waited for. A folder this
    user cannot write (an archived run) is read without it."""
    if not os.access(run_dir, os.W_OK):
        yield
        return
    from sgpipe.stages.base import folder_lock
    with folder_lock(run_dir):
        yield


def write_report(run_dir: str | Path, out_dir: str | Path | None = None) -> Path:
    """Read `run_dir`, write its report to `out_dir` (default `run_dir/report`); returns the
    path of index.html."""
    run_dir = Path(run_dir)
    check_run_dir(run_dir)
    with _run_lock(run_dir):
        return _write(run_dir, out_dir)


def _write(run_dir: Path, out_dir: str | Path | None) -> Path:
    from sgpipe.report.page import render_page
    from sgpipe.report.plots import write_charts
    run = collect(run_dir)                           # BadInput for a folder without stages
    out_dir = Path(out_dir) if out_dir is not None else default_out(run_dir)
    _check_target(out_dir)
    with atomic_folder(out_dir, marker=MARKER, writer="sgpipe report") as staging:
        for p in pictures(run):
            dest = staging / p.href
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(p.source, dest)
        charts = write_charts(run, staging)
        (staging / INDEX).write_text(render_page(run, charts), encoding="utf-8")
    return out_dir / INDEX
