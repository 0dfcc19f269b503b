"""The host↔kernel interface from its one Python definition: records packed by the host read
back through the generated `records.h` macros in a kernel, every registry method's kernel
declared with its generated parameter list and bound by the renderer, and the config's
`render.methods` choices derived from the registry."""

import re
import typing

import numpy as np
import pytest

from sgpipe.render import opencl
from sgpipe.render.envdata import EnvData
from sgpipe.render.headers import layout_headers
from sgpipe.render.materials import Material, pack_materials
from sgpipe.render.methods import METHOD_NAMES, METHODS
from sgpipe.render.records import MAT_STRIDE, MaterialSlot, ObjectSlot
from sgpipe.render.renderer import Frame, ObjectShading, Renderer
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject, trace_gbuffer

pytestmark = pytest.mark.opencl

_SRC = """#include "records.h"
__kernel void t_records(__global const float *mats, __global const int8 *objs,
                        __global const float4 *objf, __global float *mout,
                        __global int *oout, __global float *fout) {
    __global const float *m = mats + 1 * MAT_STRIDE;        /* the second material */
    int k = 0;
%s
    int8 ob = objs[1];
%s
    fout[0] = OBJF_MAXD(objf[1]);
}
"""


def _read_back_through_macros(mats, objs, objf):
    import pyopencl as cl
    mat_lines = "\n".join(f"    mout[k++] = m[MAT_{s.name}];" for s in MaterialSlot)
    obj_lines = "\n".join(f"    oout[{i}] = OBJ_{s.name}(ob);" for i, s in enumerate(ObjectSlot))
    ctx, q = opencl.get_context()
    opts = opencl.build_options(None, ("-I", str(opencl.generated_include_dir(layout_headers()))))
    prg = cl.Program(ctx, _SRC % (mat_lines, obj_lines)).build(options=list(opts))
    outs = [opencl.empty_device(ctx, 4 * n) for n in (len(MaterialSlot), len(ObjectSlot), 1)]
    dev = opencl.to_device
    cl.Kernel(prg, "t_records")(q, (1,), None, dev(ctx, mats), dev(ctx, objs, dtype=np.int32),
                                dev(ctx, objf), *outs)
    return [opencl.read_back(q, b, (n,), dt) for b, n, dt in
            zip(outs, (len(MaterialSlot), len(ObjectSlot), 1), (np.float32, np.int32, np.float32))]


def test_packed_records_read_back_through_generated_macros():
    """What pack_materials / the renderer write at a field is what the kernels read there."""
    m = Material("x", kd=np.array([0.1, 0.2, 0.3]), ks=np.array([0.4, 0.5, 0.6]), g_scale=0.7,
                 diffuse=1, fresnel=2, f0=np.array([0.01, 0.02, 0.03]),
                 eta=np.array([1.1, 1.2, 1.3]), k=np.array([2.1, 2.2, 2.3]), shadowing=4,
                 alpha_u=0.11, alpha_v=0.22, kd_texture=5, ks_texture=6)
    table = pack_materials([Material.lambert("w", 1.0), m])
    assert table.records.shape[1] == MAT_STRIDE
    r = Renderer(env=EnvData.constant(1.0), materials=table,
                 objects=[ObjectShading(0), ObjectShading(1, normal_map=3)])
    objs, objf, *_ = r._object_records()
    mout, oout, fout = _read_back_through_macros(table.records, objs, objf)
    got = dict(zip((s.name for s in MaterialSlot), mout))
    for name, want in (("KD", 0.1), ("KS", 0.4), ("GSCALE", 0.7), ("DIFFUSE", 1),
                       ("FRESNEL", 2), ("F0", 0.01), ("ETA", 1.1), ("K", 2.1), ("SHADOW", 4),
                       ("AU", 0.11), ("AV", 0.22), ("KDTEX", 5), ("KSTEX", 6), ("GMM", -1)):
        assert got[name] == pytest.approx(want), name
    obj = dict(zip((s.name for s in ObjectSlot), oout))
    assert (obj["MAT"], obj["NMAP"], obj["HAS_SSDF"], obj["RES"]) == (1, 3, 0, 1)
    assert fout[0] == pytest.approx(np.pi / 2)


def test_every_registry_method_is_declared_and_launches():
    """Each method's kernel file declares `__kernel void <kernel>(<KERNEL>_ARGS)` and the
    renderer binds every parameter of the registry's list (a launch on a lit sphere pixel)."""
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), width=1, height=1, fov_deg=10)
    fr = Frame.from_gbuffer(trace_gbuffer([TraceObject.sphere("s", (0, 0, 0), 1.0)], *cam.rays()))
    r = Renderer(env=EnvData.constant(1.0), materials=pack_materials([Material.lambert("w", 1)]),
                 objects=[ObjectShading(0)])
    for name, m in METHODS.items():
        src = (opencl.kernel_dir() / f"{m.kernel}.cl").read_text()
        assert re.search(rf"__kernel void {m.kernel}\({m.kernel.upper()}_ARGS\)", src), name
        rgb = r.shade(name, fr)
        if m.needs_transport:   # no transport data attached: the object has nothing to shade
            assert rgb.shape == (1, 3) and np.all(rgb == 0), (name, rgb)
            continue
        assert rgb.shape == (1, 3) and np.all(rgb > 0.5), (name, rgb)   # white furnace: 1


def test_config_methods_are_the_registry_and_reference():
    from sgpipe.config.sections.render import RenderSection
    (item,) = typing.get_args(typing.get_type_hints(RenderSection)["methods"])
    assert typing.get_args(item) == METHOD_NAMES == (*METHODS, "reference")
