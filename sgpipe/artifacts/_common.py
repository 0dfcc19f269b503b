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
    `write_npz`, `write_png`, `write_json`). A stage's `StageRun` is one (writing into its
    staging folder, with sgpipe's EXR metadata from `meta`); tests and tools use it directly."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)

    def path(self, name: str) -> Path:
        """Path of an output file inside the folder (sub-folders are created)."""
        p = self.root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def meta(self, extra: dict | None = None) -> dict:
        """EXR metadata: the writer's own; a stage adds its version, name and parameter hash."""
        return dict(extra or {})

    def write_exr(self, name: str, image: np.ndarray, *, metadata: dict | None = None,
                  half: bool = False, png: bool = True, exposure: float = 0.0,
                  channel_names: list[str] | None = None) -> Path:
        """EXR plus a PNG preview beside it (image artifacts get one)."""
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
        p.write_text(json.dumps(jsonable(data), indent=2, sort_keys=True) + "\n")
        return p


def jsonable(x: Any) -> Any:
    """Plain JSON data from reports holding numpy values and paths."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, np.floating):
        return float(x)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, Path):
        return str(x)
    return x


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
