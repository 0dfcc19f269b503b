"""`sgpipe doctor`: report the runtime pieces sgpipe needs, with a one-line fix for each gap."""

from __future__ import annotations

import importlib

import click
import numpy as np


def check_opencl() -> tuple[bool, list[str]]:
    """List platforms/devices, then build and run a tiny kernel on the device the renderer
    uses (`sgpipe.render.opencl.pick_device`)."""
    lines = []
    try:
        import pyopencl as cl
    except Exception as e:  # noqa: BLE001 - report any import failure
        return False, [f"pyopencl: not importable ({e}); fix: pip install pyopencl"]
    lines.append(f"pyopencl {cl.VERSION_TEXT}")
    from sgpipe.errors import BadInput
    from sgpipe.render.opencl import pick_device, platform_devices
    for p, devs in platform_devices(cl):
        lines.append(f"  platform: {p.name} ({p.version})")
        for d in devs:
            lines.append(f"    device: {d.name} [{cl.device_type.to_string(d.type)}], "
                         f"{d.max_compute_units} compute units, "
                         f"{d.global_mem_size / 2**30:.1f} GiB")
    try:
        dev = pick_device(cl)
    except BadInput as e:
        return False, lines + [e.one_line()]
    ctx = cl.Context([dev])
    q = cl.CommandQueue(ctx)
    prg = cl.Program(ctx, "__kernel void sq(__global float *a)"
                          "{ int i = get_global_id(0); a[i] = a[i] * a[i]; }").build()
    a = np.arange(16, dtype=np.float32)
    buf = cl.Buffer(ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=a)
    prg.sq(q, a.shape, None, buf)
    out = np.empty_like(a)
    cl.enqueue_copy(q, out, buf)
    ok = bool(np.array_equal(out, a * a))
    lines.append(f"  test kernel on '{dev.name}': {'ok' if ok else 'WRONG RESULT'}")
    return ok, lines


def _version(mod: str, attr: str = "__version__") -> tuple[bool, str]:
    try:
        m = importlib.import_module(mod)
        return True, str(getattr(m, attr, "?"))
    except Exception as e:  # noqa: BLE001
        return False, f"not importable ({e}); fix: pip install -e ."


def check_embree() -> tuple[bool, str]:
    try:
        from importlib.metadata import version
        import embreex.rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh
        v = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], dtype=np.float32)
        scene = rtcs.EmbreeScene()
        TriangleMesh(scene, v)
        hit = scene.run(np.array([[0.2, 0.2, 1.0]], np.float32),
                        np.array([[0, 0, -1.0]], np.float32), output=0)
        return bool(hit[0] == 0), f"embreex {version('embreex')} (test ray: " \
                                  f"{'hit' if hit[0] == 0 else 'MISSED'})"
    except Exception as e:  # noqa: BLE001
        return False, f"embreex: not working ({e}); fix: pip install embreex"


def run_doctor() -> int:
    """Print the report; return 0 when everything works, 1 otherwise."""
    import sgpipe
    ok_all = True
    click.echo(f"sgpipe {sgpipe.__version__}")
    for mod, name in (("numpy", "numpy"), ("numba", "numba"), ("scipy", "scipy"),
                      ("trimesh", "trimesh"), ("OpenImageIO", "OpenImageIO")):
        ok, v = _version(mod)
        ok_all &= ok
        click.echo(f"{name}: {v}")
    ok, line = check_embree()
    ok_all &= ok
    click.echo(line)
    ok, lines = check_opencl()
    ok_all &= ok
    for ln in lines:
        click.echo(ln)
    click.echo("doctor: all good" if ok_all else "doctor: problems found (see the fix above)")
    return 0 if ok_all else 1
