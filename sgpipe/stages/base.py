"""StageRun: staging folder, manifest, skip-if-unchanged, atomic publish.

Usage inside a stage:

    with StageRun(cfg, out_dir, "envmap", params=to_plain(cfg.envmap),
                  inputs=[env_path], force=force) as run:
        if run.skipped:
            return run
        img = ...
        run.write_exr("pyramid_level0.exr", img, metadata={"lambda": 12.0})
        run.write_npz("light_fit.npz", {...})
        run.report["irradiance_rel_err"] = 0.004   # deterministic facts -> manifest
        run.timings["pyramid_s"] = 0.8             # wall-clock -> timings.json (not hashed)

Everything is written into `<out>/.<stage>.staging/` (scratch files that are not outputs into
`run.scratch_dir()`, `<out>/.<stage>.tmp/`); on success the manifest and resolved config are
added and the folder replaces `<out>/<stage>/`. On any exception — KeyboardInterrupt and the
CLI's SIGINT/SIGTERM exception included — the staging and scratch folders are deleted and the
previous outputs stay as they were: nothing half-written.

A run holds an exclusive lock on its output folder (`folder_lock`; the CLI holds it for a whole
command): a second run on the same folder waits, then finds the stages up to date. The skip
check re-hashes every output the manifest names, so a deleted or truncated artifact reruns its
stage. Input files are recorded by location-independent keys (`input_key`), so the manifest's
bytes do not depend on where the output folder is.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import json
import os
import shutil
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

import yaml

import sgpipe
from sgpipe.config.schema import to_plain
from sgpipe.errors import BadInput
from sgpipe.artifacts._common import FolderSink, jsonable
from sgpipe.io import file_hash


def code_files() -> list[Path]:
    """The sgpipe package's own code: Python modules and the OpenCL kernels (.cl, .h)."""
    root = Path(sgpipe.__file__).resolve().parent
    return sorted(p for p in root.rglob("*") if p.suffix in (".py", ".cl", ".h")
                  and "__pycache__" not in p.parts)


@functools.lru_cache(maxsize=1)
def code_hash() -> str:
    """Hash of `code_files()` (paths and contents): part of every stage's cache key, so a code
    change re-runs stages instead of reusing artifacts made by older code."""
    root = Path(sgpipe.__file__).resolve().parent
    h = hashlib.sha256()
    for f in code_files():
        h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def params_hash(params: Any) -> str:
    """Stable hash of resolved parameters (JSON with sorted keys)."""
    blob = json.dumps(params, sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()[:16]


def check_writable(out_dir: Path) -> None:
    """BadInput (exit 2) when the output folder cannot be created or written."""
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        probe = out_dir / f".sgpipe-write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as e:
        raise BadInput(f"output folder is not writable ({e.strerror})", file=out_dir,
                       key="--out") from None


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


_LOCKS: dict[str, list] = {}     # resolved folder -> [fd, depth]: this process's held locks


@contextlib.contextmanager
def folder_lock(out_dir: str | Path):
    """Hold an exclusive flock on the output folder (created if missing). Re-entrant within a
    process; another process waits, after saying so in one line. A folder this call created
    and left empty (e.g. a bad input before any stage wrote) is removed again."""
    out_dir = Path(out_dir)
    created = not out_dir.exists()
    check_writable(out_dir)
    key = str(out_dir.resolve())
    if key in _LOCKS:
        _LOCKS[key][1] += 1
        try:
            yield
        finally:
            _LOCKS[key][1] -= 1
        return
    fd = _acquire(out_dir, key)
    _LOCKS[key] = [fd, 1]
    try:
        yield
    finally:
        del _LOCKS[key]
        if created:
            with contextlib.suppress(OSError):
                out_dir.rmdir()        # only succeeds when empty
        os.close(fd)                   # releases the lock


def _acquire(out_dir: Path, key: str) -> int:
    """fd of the folder, exclusively locked; retried if the folder was replaced meanwhile (a
    waiter may have locked a folder that the previous holder removed)."""
    said = False
    while True:
        os.makedirs(key, exist_ok=True)
        fd = os.open(key, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                if not said:
                    log(f"sgpipe: waiting for another sgpipe run on {out_dir} to finish ...")
                    said = True
                fcntl.flock(fd, fcntl.LOCK_EX)      # interruptible: EINTR runs the handlers
            st = os.fstat(fd)
            if os.path.exists(key) and os.path.samestat(st, os.stat(key)):
                return fd
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)


@contextlib.contextmanager
def _signals_deferred():
    """SIGINT / SIGTERM (and SIGALRM when it has a Python handler: the CLI re-raises a
    swallowed interruption with it) that arrive inside the block are delivered when it ends: a
    publish (hash outputs, write the manifest, swap the folders) is never cut half-way."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []
    old = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGALRM)}
    deferred = [s for s, h in old.items()
                if h not in (signal.SIG_IGN, None) and (s != signal.SIGALRM or callable(h))]
    for s in deferred:
        signal.signal(s, lambda signum, frame: pending.append(signum))
    try:
        yield
    finally:
        for s in deferred:
            signal.signal(s, old[s])
        for s in dict.fromkeys(pending):
            signal.raise_signal(s)


def input_key(path: Path, out_dir: Path, config_dir: Path | None) -> str:
    """Location-independent manifest key of an input file: `<out>/...` relative to the output
    folder for files inside it, `<config>/...` relative to the config file's folder otherwise
    (the absolute path only when there is no config file)."""
    path = path.resolve()
    out_dir = out_dir.resolve()
    if path.is_relative_to(out_dir):
        return "<out>/" + path.relative_to(out_dir).as_posix()
    if config_dir is not None:
        return "<config>/" + Path(os.path.relpath(path, config_dir.resolve())).as_posix()
    return path.as_posix()


def resolved_config(cfg) -> dict:
    """The config as a stage folder's config.resolved.yaml records it (plain values)."""
    resolved = to_plain(cfg) if cfg is not None else {}
    if isinstance(resolved, dict):
        resolved.pop("source", None)
        # where and on how many processes the chunks ran is not what was computed: local,
        # Dask and any worker count give the same bytes
        resolved.pop("scheduler", None)
        resolved.pop("workers", None)
    return resolved


class StageRun(FolderSink):
    """One stage's run: see the module docstring."""

    def __init__(self, cfg, out_dir: str | Path, stage: str, *, params: Any,
                 inputs: list[str | Path] = (), force: bool = False):
        self.cfg = cfg
        self.out_dir = Path(out_dir)
        self.stage = stage
        self.params = to_plain(params)
        self.inputs = sorted({Path(p).resolve() for p in inputs})
        self.force = force
        self.final_dir = self.out_dir / stage
        self.staging = self.out_dir / f".{stage}.staging"
        super().__init__(self.staging)
        self.scratch = self.out_dir / f".{stage}.tmp"
        self.report: dict[str, Any] = {}
        self.timings: dict[str, float] = {}
        self.skipped = False
        self._t0 = 0.0
        self._lock = None

    # -- identity -------------------------------------------------------------------------
    def _input_hashes(self) -> dict[str, str]:
        source = getattr(self.cfg, "source", None)
        config_dir = Path(source).parent if source is not None else None
        out = {}
        for path in self.inputs:
            if not path.is_file():
                raise BadInput("input file not found", file=path, key=self.stage)
            out[input_key(path, self.out_dir, config_dir)] = file_hash(path)
        return dict(sorted(out.items()))

    @property
    def param_hash(self) -> str:
        """What the config asks of this stage (stage, seed, parameters; input files by their
        path from the config's folder). Written into every EXR; the code is not part of it, so
        a change that moves no number leaves the artifacts' bytes alone."""
        return params_hash({"stage": self.stage, "seed": getattr(self.cfg, "seed", 0),
                            "params": self.params})

    def _up_to_date(self, input_hashes: dict[str, str]) -> bool:
        man_path = self.final_dir / "manifest.json"
        if self.force or not man_path.is_file():
            return False
        try:
            man = json.loads(man_path.read_text())
        except (OSError, ValueError):
            return False
        if not isinstance(man, dict) or not isinstance(man.get("outputs"), dict):
            return False
        if (man.get("param_hash") != self.param_hash or man.get("code_hash") != code_hash()
                or man.get("sgpipe_version") != sgpipe.__version__
                or man.get("inputs") != input_hashes):
            return False
        # Every output the manifest names must be there with its recorded bytes: a deleted or
        # truncated artifact makes the stage run again instead of failing downstream.
        for name, digest in man["outputs"].items():
            p = self.final_dir / name
            try:
                same = p.is_file() and file_hash(p) == digest
            except OSError as e:            # unreadable (permissions, I/O error)
                log(f"[{self.stage}] {p} is unreadable ({e.strerror}): rerunning")
                return False
            if not same:
                log(f"[{self.stage}] {p} is missing or changed since it was written: rerunning")
                return False
        return True

    def scratch_dir(self) -> Path:
        """A private folder for temporary files that are not outputs (memory-mapped arrays,
        files shared with workers); deleted when the stage ends, however it ends."""
        self.scratch.mkdir(parents=True, exist_ok=True)
        return self.scratch

    def _refuse_foreign_folder(self) -> None:
        """A non-empty OUT/<stage> folder with none of the files every stage writes is the
        user's own: publishing would replace (delete) it, so say so instead."""
        d = self.final_dir
        if not d.is_dir() or not any(d.iterdir()):
            return
        if not any((d / n).is_file() for n in ("manifest.json", "config.resolved.yaml",
                                                "timings.json")):
            raise BadInput(f"exists and was not written by sgpipe (no manifest.json); the "
                           f"{self.stage} stage would replace it: move it away or choose "
                           "another --out", file=d, key="--out")

    def _remove_leftovers(self) -> None:
        """Staging / scratch / swap folders of a run of this stage that was killed (SIGKILL,
        power loss); safe because this process holds the folder lock."""
        st = self.stage
        for p in [*self.out_dir.glob(f".{st}.staging"), *self.out_dir.glob(f".{st}.tmp*"),
                  *self.out_dir.glob(f".{st}.old")]:
            shutil.rmtree(p, ignore_errors=True)

    # -- context manager ------------------------------------------------------------------
    def __enter__(self) -> "StageRun":
        self._lock = folder_lock(self.out_dir)
        self._lock.__enter__()
        try:
            self._remove_leftovers()
            self._refuse_foreign_folder()
            self._input_hash_map = self._input_hashes()
            if self._up_to_date(self._input_hash_map):
                self.skipped = True
                log(f"[{self.stage}] up to date: inputs and parameters unchanged "
                    f"(skipped; --force reruns) -> {self.final_dir}")
                return self
            self.staging.mkdir(parents=True)
            self._t0 = time.perf_counter()
            log(f"[{self.stage}] running -> {self.final_dir}")
            return self
        except BaseException:
            self._release()
            raise

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if self.skipped:
                return False
            try:
                if exc_type is None:
                    shutil.rmtree(self.scratch, ignore_errors=True)
                    with _signals_deferred():     # a signal now lands after the publish
                        self._publish()
            finally:
                # after a failure, or a publish cut short: nothing half-written stays
                shutil.rmtree(self.staging, ignore_errors=True)
                shutil.rmtree(self.scratch, ignore_errors=True)
            return False
        finally:
            self._release()

    def _release(self) -> None:
        lock, self._lock = self._lock, None
        if lock is not None:
            lock.__exit__(None, None, None)

    def _publish(self) -> None:
        self.timings.setdefault("total_s", time.perf_counter() - self._t0)
        resolved = resolved_config(self.cfg)
        (self.staging / "config.resolved.yaml").write_text(
            "# input files are relative to the folder of the config this run read\n"
            + yaml.safe_dump(resolved, sort_keys=True))
        outputs = {}
        for p in sorted(self.staging.rglob("*")):
            if p.is_file():
                outputs[p.relative_to(self.staging).as_posix()] = file_hash(p)
        manifest = {
            "stage": self.stage,
            "sgpipe_version": sgpipe.__version__,
            "param_hash": self.param_hash,
            "code_hash": code_hash(),
            "params": self.params,
            "inputs": self._input_hash_map,
            "outputs": outputs,
            "report": jsonable(self.report),
        }
        (self.staging / "manifest.json").write_text(json.dumps(manifest, indent=2,
                                                               sort_keys=True) + "\n")
        (self.staging / "timings.json").write_text(json.dumps(
            {k: round(float(v), 6) for k, v in self.timings.items()}, indent=2,
            sort_keys=True) + "\n")
        old = self.out_dir / f".{self.stage}.old"
        if old.exists():
            shutil.rmtree(old)
        if self.final_dir.exists():
            os.replace(self.final_dir, old)
        os.replace(self.staging, self.final_dir)
        shutil.rmtree(old, ignore_errors=True)
        log(f"[{self.stage}] wrote {len(outputs)} files in {self.timings['total_s']:.2f} s "
            f"-> {self.final_dir}")

    # -- writers (FolderSink's, into the staging folder) -----------------------------------
    def meta(self, extra: dict | None = None) -> dict:
        return {"version": sgpipe.__version__, "stage": self.stage,
                "param_hash": self.param_hash, **(extra or {})}
