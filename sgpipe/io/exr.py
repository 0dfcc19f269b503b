"""EXR read/write through OpenImageIO, with sgpipe metadata and input validation."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io.atomic import atomic_path
from sgpipe.io.disk import raise_if_disk_full


def _oiio():
    import OpenImageIO as oiio  # imported lazily: keeps `sgpipe --help` fast
    return oiio


def oiio_error(source) -> str:
    """OpenImageIO's pending error message from `source` (the module or an ImageInput /
    ImageOutput), stripped; a damaged file's bytes can make it undecodable as UTF-8."""
    try:
        return " ".join(str(source.geterror()).split())
    except UnicodeDecodeError:
        return "an error message that is not UTF-8 text"


def write_exr(path: str | os.PathLike, image: np.ndarray, *, half: bool = False,
              metadata: dict | None = None, channel_names: list[str] | None = None) -> Path:
    """Write an (H, W) or (H, W, C) float image atomically. `metadata` values become EXR
    string/float/int attributes under the `sgpipe:` prefix (version, stage, parameter hash...)."""
    oiio = _oiio()
    path = Path(path)
    img = np.asarray(image, dtype=np.float32)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3:
        raise ValueError(f"write_exr expects (H, W[, C]), got shape {img.shape}")
    h, w, c = img.shape
    fmt = oiio.HALF if half else oiio.FLOAT
    spec = oiio.ImageSpec(w, h, c, fmt)
    if channel_names is None:
        channel_names = {1: ["Y"], 3: ["R", "G", "B"], 4: ["R", "G", "B", "A"]}.get(
            c, [f"c{i}" for i in range(c)])
    spec.channelnames = tuple(channel_names)
    spec.attribute("compression", "zip")
    # Pin everything OIIO would otherwise fill from the environment so bytes are reproducible.
    spec.attribute("Software", "sgpipe")
    spec.attribute("DateTime", "0000:00:00 00:00:00")  # OpenEXR would stamp the wall clock
    for key, value in sorted((metadata or {}).items()):
        if isinstance(value, bool):
            value = int(value)
        if isinstance(value, (int, np.integer)):
            spec.attribute(f"sgpipe:{key}", int(value))
        elif isinstance(value, (float, np.floating)):
            spec.attribute(f"sgpipe:{key}", float(value))
        else:
            spec.attribute(f"sgpipe:{key}", str(value))
    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create(str(tmp))
        if out is None or not out.open(str(tmp), spec):
            _write_failed(path, oiio_error(oiio), img.nbytes)
        ok = out.write_image(np.ascontiguousarray(img))
        out.close()
        if not ok:
            _write_failed(path, oiio_error(out), img.nbytes)
    return path


def _write_failed(path: Path, why: str, nbytes: int):
    """A failed write: a full disk (less free space than the raw pixels, an upper bound of the
    compressed file) as OSError(ENOSPC), else one BadInput line."""
    raise_if_disk_full(path, nbytes)
    raise BadInput(f"cannot write EXR: {why}", file=path)


def read_exr(path: str | os.PathLike, *, channels: tuple[int, ...] | None = None,
             key: str | None = None, allow_nonfinite: bool = False,
             with_metadata: bool = False):
    """Read an image as float32 (H, W, C). Rejects unreadable files, NaN/Inf and, when
    `channels` is given, a channel count not in it — each as one BadInput line naming the file."""
    oiio = _oiio()
    path = Path(path)
    if not path.is_file():
        raise BadInput("file not found", file=path, key=key)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise BadInput(f"unreadable image ({oiio_error(oiio) or 'unknown format'})",
                       file=path, key=key)
    try:
        spec = inp.spec()
        data = inp.read_image(oiio.FLOAT)
        err = oiio_error(inp)
    finally:
        inp.close()
    if data is None or (isinstance(data, np.ndarray) and data.size == 0):
        raise BadInput(f"unreadable image ({err or 'no pixels'})", file=path, key=key)
    img = np.asarray(data, dtype=np.float32)
    if img.ndim == 2:
        img = img[:, :, None]
    if channels is not None and img.shape[2] not in channels:
        want = " or ".join(str(c) for c in channels)
        raise BadInput(f"has {img.shape[2]} channels, expected {want}", file=path, key=key)
    if not allow_nonfinite and not np.isfinite(img).all():
        bad = int((~np.isfinite(img)).any(axis=2).sum())
        raise BadInput(f"contains NaN/Inf in {bad} pixels", file=path, key=key)
    if with_metadata:
        meta = {}
        for attr in spec.extra_attribs:
            if attr.name.startswith("sgpipe:"):
                meta[attr.name[len("sgpipe:"):]] = attr.value
        return img, meta
    return img
