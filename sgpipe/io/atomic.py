"""Atomic file and folder writes (a temporary beside the target + rename) and content hashes."""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
from pathlib import Path

from sgpipe.errors import BadInput


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None):
    """Yield a temporary path beside `path`; rename it over `path` only if the block succeeds.

    The temporary name keeps the extension (OpenImageIO picks the format from it).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ext = suffix if suffix is not None else "".join(path.suffixes[-1:])
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}{ext}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike, *, marker: str, writer: str):
    """Yield an empty staging folder beside `path`; when the block succeeds, write `marker`
    (naming `writer`) into it and swap it in for `path`. On any exception, Ctrl-C included, the
    staging folder and the parent folders this created are removed and a previous `path` stays
    as it was. BadInput (key --out) when the place is not writable."""
    path = Path(path)
    made = []                       # parents created here, innermost first
    p = path.parent
    while not p.exists():
        made.append(p)
        p = p.parent
    staging = path.parent / f".{path.name}.staging-{os.getpid()}"
    old = path.parent / f".{path.name}.old-{os.getpid()}"
    try:
        try:
            staging.mkdir(parents=True)
        except OSError as e:
            raise BadInput(f"output folder is not writable ({e.strerror})", file=path.parent,
                           key="--out") from None
        yield staging
        (staging / marker).write_text(f"written by `{writer}`; replaced by the next one\n")
        if path.exists():
            os.replace(path, old)
        os.replace(staging, path)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        if old.exists() and not path.exists():
            os.replace(old, path)   # put the previous folder back
        for q in made:
            try:
                q.rmdir()
            except OSError:
                break
        raise
    shutil.rmtree(old, ignore_errors=True)


def file_hash(path: str | os.PathLike, algo: str = "sha256") -> str:
    """Hex digest of a file's bytes."""
    h = hashlib.new(algo)
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
