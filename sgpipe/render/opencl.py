"""OpenCL runtime: one context/queue per process, `.cl` programs from package data, memoized
builds per (context, program, options).

    ctx, queue = get_context()
    prg = build_program(ctx, "sg_shade", defines={"NV": 48, "MAX_LOBES": 8})
    prg.sg_shade(queue, (n,), None, *buffers)

Kernels live in `sgpipe/render/kernels/<name>.cl`; shared math in `kernels/include/*.h`,
reached with `-I`, and headers generated from Python (record layouts, parameter lists, f_h
table: sgpipe.render.headers) in a second `-I` folder (pyopencl's compiler cache hashes
included headers too). A missing OpenCL
device is user-environment trouble: `BadInput` with the apt command that fixes it.
"""

from __future__ import annotations

import os
import threading
import time
from importlib import resources
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput

OPENCL_FIX = ("no OpenCL device found; fix: sudo apt-get update && sudo apt-get install -y "
              "pocl-opencl-icd (or run `make setup` as root), then check with `sgpipe doctor`")

_LOCK = threading.Lock()
_CONTEXT = None
_PROGRAMS: dict[tuple, object] = {}
#: Program builds performed by this process (name, options, seconds): for tests and timings.
BUILD_LOG: list[tuple[str, str, float]] = []


def kernel_dir() -> Path:
    """Folder holding the `.cl` files (package data) and `include/`."""
    return Path(str(resources.files("sgpipe.render") / "kernels"))


def _cl():
    try:
        import pyopencl as cl
    except Exception as e:  # noqa: BLE001 - any import failure is an environment problem
        raise BadInput(f"pyopencl is not importable ({e}); fix: pip install -e .",
                       key="opencl") from None
    return cl


def platform_devices(cl) -> list[tuple[object, list]]:
    """[(platform, its devices)] of every OpenCL platform (a platform that cannot list its
    devices shows none)."""
    try:
        platforms = cl.get_platforms()
    except cl.Error:
        platforms = []
    out = []
    for p in platforms:
        try:
            out.append((p, list(p.get_devices())))
        except cl.Error:
            out.append((p, []))
    return out


def pick_device(cl):
    """The device `get_context` uses: SGPIPE_OPENCL_DEVICE by name, else the first CPU device,
    else the first device (BadInput with the fix when there is none)."""
    devices = [d for _, ds in platform_devices(cl) for d in ds]
    if not devices:
        raise BadInput(OPENCL_FIX, key="opencl")
    want = os.environ.get("SGPIPE_OPENCL_DEVICE", "")
    if want:
        for d in devices:
            if want.lower() in d.name.lower():
                return d
    cpu = [d for d in devices if d.type & cl.device_type.CPU]
    return (cpu or devices)[0]


def get_context():
    """(context, queue) on the first CPU OpenCL device (env SGPIPE_OPENCL_DEVICE picks by name)."""
    global _CONTEXT
    with _LOCK:
        if _CONTEXT is None:
            cl = _cl()
            dev = pick_device(cl)
            ctx = cl.Context([dev])
            _CONTEXT = (ctx, cl.CommandQueue(ctx))
        return _CONTEXT


def device_name() -> str:
    ctx, _ = get_context()
    return ctx.devices[0].name


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, (float, np.floating)):
        return repr(float(v)) + "f"
    return str(v)


def build_options(defines: dict | None = None, extra: tuple[str, ...] = ()) -> tuple[str, ...]:
    """Compiler options: `-I kernels/include`, sorted `-D K=V` (floats get an `f`), extras."""
    opts = ["-I", str(kernel_dir() / "include"), "-cl-fast-relaxed-math"]
    for k in sorted(defines or {}):
        opts.append(f"-D{k}={_fmt(defines[k])}")
    return tuple(opts) + tuple(extra)


def generated_include_dir(headers: dict[str, str]) -> Path:
    """Write generated headers (name → source) into a content-addressed folder; return it."""
    import hashlib
    import tempfile
    blob = "\0".join(f"{k}\0{headers[k]}" for k in sorted(headers)).encode()
    digest = hashlib.sha256(blob).hexdigest()[:16]
    folder = Path(tempfile.gettempdir()) / f"sgpipe-cl-{os.getuid()}" / digest
    if not all((folder / k).is_file() for k in headers):
        folder.mkdir(parents=True, exist_ok=True)
        for k, text in headers.items():
            tmp = folder / f".{k}.{os.getpid()}.tmp"
            tmp.write_text(text)
            os.replace(tmp, folder / k)
    return folder


def build_program(ctx, name: str, defines: dict | None = None, extra: tuple[str, ...] = (),
                  headers: dict[str, str] | None = None):
    """Build (once per context and options) the program `kernels/<name>.cl`; `headers` are
    generated include files (name → source) besides the record layouts and parameter lists
    every build gets (headers.layout_headers), reached through an extra `-I`."""
    from sgpipe.render.headers import layout_headers
    cl = _cl()
    extra = ("-I", str(generated_include_dir({**layout_headers(), **(headers or {})}))) + \
        tuple(extra)
    opts = build_options(defines, extra)
    key = (id(ctx), name, opts)
    with _LOCK:
        prg = _PROGRAMS.get(key)
        if prg is not None:
            return prg
        src_path = kernel_dir() / f"{name}.cl"
        if not src_path.is_file():
            raise FileNotFoundError(f"missing kernel source {src_path}")
        t0 = time.perf_counter()
        try:
            prg = cl.Program(ctx, src_path.read_text()).build(options=list(opts))
        except cl.RuntimeError as e:  # compile errors are bugs: keep the build log
            log = str(e)
            raise RuntimeError(f"OpenCL build of {name}.cl failed:\n{log[:4000]}") from None
        BUILD_LOG.append((name, " ".join(opts), time.perf_counter() - t0))
        _PROGRAMS[key] = prg
        return prg


def to_device(ctx, array: np.ndarray, *, dtype=np.float32):
    """Read-only device buffer holding a contiguous copy of `array` (empty arrays get 1 elem)."""
    cl = _cl()
    a = np.ascontiguousarray(array, dtype=dtype)
    if a.size == 0:
        a = np.zeros(1, dtype)
    return cl.Buffer(ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=a)


def empty_device(ctx, nbytes: int):
    cl = _cl()
    return cl.Buffer(ctx, cl.mem_flags.READ_WRITE, size=max(int(nbytes), 4))


def read_back(queue, buf, shape, dtype=np.float32) -> np.ndarray:
    cl = _cl()
    out = np.empty(shape, dtype)
    cl.enqueue_copy(queue, out, buf)
    queue.finish()
    return out
