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

Everything is written into `<out>/.<stage>.staging/`; on success the manifest and resolved
config are added and the folder replaces `<out>/<stage>/`. On any exception the staging folder
is deleted and the previous outputs stay as they were: nothing half-written.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

import sgpipe
from sgpipe.config.schema import to_plain
from sgpipe.errors import BadInput
from sgpipe.io import file_hash, write_exr, write_npz, write_png


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


class StageRun:
    """One stage's run: see the module docstring."""

    def __init__(self, cfg, out_dir: str | Path, stage: str, *, params: Any,
                 inputs: list[str | Path] = (), force: bool = False):
        self.cfg = cfg
        self.out_dir = Path(out_dir)
        self.stage = stage
        self.params = to_plain(params)
        self.inputs = sorted({str(Path(p).resolve()) for p in inputs})
        self.force = force
        self.final_dir = self.out_dir / stage
        self.staging = self.out_dir / f".{stage}.staging"
        self.report: dict[str, Any] = {}
        self.timings: dict[str, float] = {}
        self.skipped = False
        self._t0 = 0.0

    # -- identity -------------------------------------------------------------------------
    def _input_hashes(self) -> dict[str, str]:
        out = {}
        for p in self.inputs:
            path = Path(p)
            if not path.is_file():
                raise BadInput("input file not found", file=path, key=self.stage)
            out[p] = file_hash(path)
        return out

    @property
    def param_hash(self) -> str:
        return params_hash({"version": sgpipe.__version__, "code": code_hash(),
                            "stage": self.stage, "seed": getattr(self.cfg, "seed", 0),
                            "params": self.params})

    def _up_to_date(self, input_hashes: dict[str, str]) -> bool:
        man_path = self.final_dir / "manifest.json"
        if self.force or not man_path.is_file():
            return False
        try:
            man = json.loads(man_path.read_text())
        except (OSError, ValueError):
            return False
        if man.get("param_hash") != self.param_hash or man.get("inputs") != input_hashes:
            return False
        for name, digest in man.get("outputs", {}).items():
            p = self.final_dir / name
            if not p.is_file() or file_hash(p) != digest:
                return False
        return True

    # -- context manager ------------------------------------------------------------------
    def __enter__(self) -> "StageRun":
        check_writable(self.out_dir)
        self._input_hash_map = self._input_hashes()
        if self._up_to_date(self._input_hash_map):
            self.skipped = True
            log(f"[{self.stage}] up to date: inputs and parameters unchanged "
                f"(skipped; --force reruns) -> {self.final_dir}")
            return self
        if self.staging.exists():
            shutil.rmtree(self.staging)
        self.staging.mkdir(parents=True)
        self._t0 = time.perf_counter()
        log(f"[{self.stage}] running -> {self.final_dir}")
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if self.skipped:
            return False
        if exc_type is not None:
            shutil.rmtree(self.staging, ignore_errors=True)
            return False
        try:
            self._publish()
        except BaseException:
            shutil.rmtree(self.staging, ignore_errors=True)
            raise
        return False

    def _publish(self) -> None:
        self.timings.setdefault("total_s", time.perf_counter() - self._t0)
        resolved = to_plain(self.cfg) if self.cfg is not None else {}
        if isinstance(resolved, dict):
            resolved.pop("source", None)
        (self.staging / "config.resolved.yaml").write_text(
            yaml.safe_dump(resolved, sort_keys=True))
        outputs = {}
        for p in sorted(self.staging.rglob("*")):
            if p.is_file():
                outputs[p.relative_to(self.staging).as_posix()] = file_hash(p)
        manifest = {
            "stage": self.stage,
            "sgpipe_version": sgpipe.__version__,
            "param_hash": self.param_hash,
            "params": self.params,
            "inputs": self._input_hash_map,
            "outputs": outputs,
            "report": _jsonable(self.report),
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

    # -- writers --------------------------------------------------------------------------
    def path(self, name: str) -> Path:
        """Path of an output file inside the staging folder (sub-folders allowed)."""
        p = self.staging / name
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def meta(self, extra: dict | None = None) -> dict:
        return {"version": sgpipe.__version__, "stage": self.stage,
                "param_hash": self.param_hash, **(extra or {})}

    def write_exr(self, name: str, image: np.ndarray, *, metadata: dict | None = None,
                  half: bool = False, png: bool = True, exposure: float = 0.0,
                  channel_names: list[str] | None = None) -> Path:
        """EXR with sgpipe metadata, plus a PNG preview beside it (image artifacts get one)."""
        p = write_exr(self.path(name), image, half=half, metadata=self.meta(metadata),
                      channel_names=channel_names)
        if png and np.asarray(image).ndim in (2, 3):
            write_png(p.with_suffix(".png"), image, exposure=exposure)
        return p

    def write_npz(self, name: str, arrays: dict[str, np.ndarray]) -> Path:
        return write_npz(self.path(name), arrays)

    def write_png(self, name: str, image: np.ndarray, **kw) -> Path:
        return write_png(self.path(name), image, **kw)

    def write_json(self, name: str, data: Any) -> Path:
        p = self.path(name)
        p.write_text(json.dumps(_jsonable(data), indent=2, sort_keys=True) + "\n")
        return p


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, Path):
        return str(x)
    return x
