"""Deterministic NPZ: `np.savez` stamps zip entries with the wall clock, so two runs of the same
config would differ byte-wise. This writer pins the timestamp and entry order."""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io.atomic import atomic_path

_EPOCH = (1980, 1, 1, 0, 0, 0)


def write_npz(path: str | os.PathLike, arrays: dict[str, np.ndarray], *,
              compress: bool = True) -> Path:
    """Write `arrays` (name -> array, no object dtypes) atomically; byte-identical for equal input."""
    path = Path(path)
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", compression=method) as zf:
            for name in sorted(arrays):
                arr = np.asarray(arrays[name])
                if arr.dtype == object:
                    raise TypeError(f"write_npz: {name} has object dtype")
                buf = io.BytesIO()
                # not ascontiguousarray: it turns 0-d scalars into shape (1,)
                np.lib.format.write_array(buf, np.array(arr, order="C", copy=True),
                                          allow_pickle=False)
                info = zipfile.ZipInfo(name + ".npy", date_time=_EPOCH)
                info.compress_type = method
                info.external_attr = 0o644 << 16
                zf.writestr(info, buf.getvalue())
    return path


def read_npz(path: str | os.PathLike, *, key: str | None = None,
             required: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """Load every array of an NPZ (allow_pickle=False); missing `required` names are BadInput."""
    path = Path(path)
    if not path.is_file():
        raise BadInput("file not found", file=path, key=key)
    try:
        with np.load(path, allow_pickle=False) as z:
            out = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as e:
        # EOFError: an empty file (left uncaught, click turned it into a bare "aborted")
        raise BadInput(f"unreadable NPZ ({e or type(e).__name__})", file=path,
                       key=key) from None
    missing = [r for r in required if r not in out]
    if missing:
        raise BadInput(f"missing arrays {missing}", file=path, key=key)
    return out
