"""Helpers the stage contracts share: a plain-folder writer with a stage's writing interface,
stored-scalar and shape checks that turn malformed files into one BadInput line."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io import read_exr, write_exr, write_npz, write_png


class FolderSink:
    """Writes artifacts into a folder with the interface the writers use (`write_exr`,
    `write_npz`, `write_png`, `write_json`; a stage's `StageRun` has the same one plus its
    manifest): for tests and tools that produce artifacts without running a stage."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)

    def path(self, name: str) -> Path:
        p = self.root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def write_exr(self, name: str, image: np.ndarray, *, metadata: dict | None = None,
                  png: bool = True, channel_names: list[str] | None = None,
                  exposure: float = 0.0) -> Path:
        p = write_exr(self.path(name), image, metadata=metadata, channel_names=channel_names)
        if png and np.asarray(image).ndim in (2, 3):
            write_png(p.with_suffix(".png"), image, exposure=exposure)
        return p

    def write_npz(self, name: str, arrays: dict[str, np.ndarray]) -> Path:
        return write_npz(self.path(name), arrays)

    def write_png(self, name: str, image: np.ndarray, **kw) -> Path:
        return write_png(self.path(name), image, **kw)

    def write_json(self, name: str, data: Any) -> Path:
        p = self.path(name)
        p.write_text(json.dumps(data, indent=2, sort_keys=True, default=_plain) + "\n")
        return p


def _plain(x):
    """JSON for numpy values and paths (what reports and microfacet.json hold)."""
    if isinstance(x, (np.ndarray, np.generic)):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"{type(x).__name__} is not JSON serializable")


def scalar(a) -> float:
    """A stored scalar (0-d, or (1,) from older writers) as float."""
    return float(np.asarray(a, np.float64).reshape(-1)[0])


def cast(arrays: dict, dtypes: dict, what: str) -> dict:
    """`arrays` converted to the contract's dtypes (None: keep, e.g. strings); a missing or
    extra name is a programming error of the producer, not bad input."""
    if set(arrays) != set(dtypes):
        raise ValueError(f"{what}: arrays {sorted(arrays)} do not match the contract's "
                         f"{sorted(dtypes)}")
    return {k: np.asarray(arrays[k]) if t is None else np.asarray(arrays[k], t)
            for k, t in dtypes.items()}


def shaped(a, shape: tuple, name: str, file, key: str | None) -> np.ndarray:
    """`a` as float64 of `shape` (−1: any length); another shape is BadInput naming the file."""
    a = np.asarray(a, np.float64)
    if a.ndim != len(shape) or any(s not in (-1, n) for s, n in zip(shape, a.shape)):
        want = "(" + ", ".join("K" if s == -1 else str(s) for s in shape) + ")"
        raise BadInput(f"{name} has shape {a.shape}, expected {want}", file=file, key=key)
    return a


def read_rgb(path: Path, key: str | None, shape: tuple | None = None,
             why: str = "") -> np.ndarray:
    """An RGB(A) EXR's first three channels, float32; `shape` (H, W, 3) checked."""
    img = read_exr(path, channels=(3, 4), key=key)[..., :3]
    if shape is not None and img.shape != tuple(shape):
        raise BadInput(f"shape {img.shape}, {why} needs {tuple(shape)}", file=path, key=key)
    return img
