"""A full disk as one line: space reserved up front for memory-mapped scratch files, and the
message every ENOSPC write error becomes (docs/CONVENTIONS.md: Errors)."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import numpy as np

#: errno values that mean "the disk (or the user's quota) is full"
FULL = (errno.ENOSPC, errno.EDQUOT)


def disk_full_error(e: BaseException | None) -> OSError | None:
    """The OSError saying the disk is full in `e` or its cause / context chain, else None."""
    seen = set()
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        if isinstance(e, OSError) and e.errno in FULL:
            return e
        e = e.__cause__ or e.__context__
    return None


def disk_full_line(e: OSError) -> str:
    """'FILE: no space left on device (… MB free there)' for a disk-full OSError."""
    msg = e.strerror or ""
    if not msg.startswith("no space left on device"):
        msg = disk_full_message(e.filename)
    return f"{e.filename}: {msg}" if e.filename else msg


def disk_full_message(path: str | os.PathLike | None, need: int | None = None) -> str:
    """'no space left on device (… MB free there[, … MB needed])' for `path`'s file system."""
    where = Path(path) if path else Path.cwd()
    probe = where
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    try:
        free = f"{shutil.disk_usage(probe).free / 1e6:.1f} MB free there"
    except OSError:
        free = "free space unknown"
    extra = f", {need / 1e6:.1f} MB needed" if need else ""
    return f"no space left on device ({free}{extra})"


def raise_if_disk_full(path: str | os.PathLike, nbytes: int) -> None:
    """For writers whose library reports no errno (OpenImageIO): a failed write of about
    `nbytes` (an upper bound of the file) with less free space than that beside `path` is a
    full disk, raised as OSError(ENOSPC, path); otherwise nothing happens and the caller
    reports its own error."""
    try:
        free = shutil.disk_usage(Path(path).parent).free
    except OSError:
        return
    if free < nbytes + (1 << 16):
        raise OSError(errno.ENOSPC, disk_full_message(path, nbytes), str(path))


def allocated_memmap(path: str | os.PathLike, dtype, shape) -> None:
    """Create `path` as a zero-filled file for an np.memmap of `shape`, its blocks reserved
    now (posix_fallocate): a sparse file on a disk that fills later kills the process that
    writes through the map with SIGBUS, far from any handler. OSError(ENOSPC, path) when the
    space is not there."""
    nbytes = int(np.prod(shape, dtype=np.int64)) * np.dtype(dtype).itemsize
    with open(path, "wb") as fh:
        if nbytes:
            try:
                os.posix_fallocate(fh.fileno(), 0, nbytes)
            except OSError as e:
                if e.errno in FULL:
                    raise OSError(e.errno, disk_full_message(path, nbytes), str(path)) from None
                if e.errno not in (errno.EOPNOTSUPP, errno.EINVAL):
                    raise
                fh.truncate(nbytes)     # a file system without fallocate: sparse, as before


__all__ = ["FULL", "disk_full_error", "disk_full_line", "disk_full_message",
           "raise_if_disk_full", "allocated_memmap"]
