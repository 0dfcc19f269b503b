"""OpenCL runtime: package-data kernels, builds memoized per (context, options), the one-line
error without a device, and every shading program compiling on PoCL."""

from importlib import resources

import numpy as np
import pytest

from sgpipe.errors import BadInput
from sgpipe.render import opencl

pytestmark = pytest.mark.opencl


def test_kernels_are_package_data():
    kdir = resources.files("sgpipe.render") / "kernels"
    names = {p.name for p in kdir.iterdir()}
    assert {"sg_shade.cl", "gmm_shade.cl", "fis_shade.cl", "selftest.cl"} <= names
    inc = {p.name for p in (kdir / "include").iterdir()}
    assert {"sg.h", "ssdf.h", "cubemap.h", "microfacet.h", "shading.h"} <= inc
    # pyproject ships exactly these globs
    text = (opencl.kernel_dir().parents[2] / "pyproject.toml").read_text()
    assert '"kernels/*.cl", "kernels/include/*.h"' in text


def test_build_is_memoized_per_context_and_options():
    ctx, q = opencl.get_context()
    assert opencl.get_context()[0] is ctx
    n0 = len(opencl.BUILD_LOG)
    a = opencl.build_program(ctx, "selftest", {"NV": 2, "FH_A": 1.05, "FH_C3": 0.204,
                                               "FH_C2": -0.892, "FH_C1": 2.995, "FH_C0": 0.067})
    b = opencl.build_program(ctx, "selftest", {"FH_C0": 0.067, "FH_C1": 2.995, "FH_C2": -0.892,
                                               "FH_C3": 0.204, "FH_A": 1.05, "NV": 2})
    assert a is b
    assert len(opencl.BUILD_LOG) - n0 <= 1
    opts = opencl.build_options({"X": 1.5, "Y": True, "Z": 3})
    assert "-DX=1.5f" in opts and "-DY=1" in opts and "-DZ=3" in opts
    assert opts[0] == "-I" and opts[1].endswith("include")


def test_no_device_is_one_line_bad_input(monkeypatch):
    import pyopencl as cl
    monkeypatch.setattr(opencl, "_CONTEXT", None)
    monkeypatch.setattr(cl, "get_platforms", lambda: [])
    with pytest.raises(BadInput) as e:
        opencl.get_context()
    msg = e.value.one_line()
    assert "\n" not in msg and "apt-get install -y pocl-opencl-icd" in msg


def test_shading_programs_build_on_pocl():
    from sgpipe.render.envdata import EnvData
    from sgpipe.render.materials import Material, pack_materials
    from sgpipe.render.methods import METHODS
    from sgpipe.render.renderer import ObjectShading, Renderer
    r = Renderer(env=EnvData.constant(1.0), materials=pack_materials([Material.lambert("w", 1)]),
                 objects=[ObjectShading(0)])
    for method in METHODS:
        assert r.kernel(method) is r.kernel(method)
    assert "sg_build_s" in r.timings
    dev = opencl.device_name()
    assert isinstance(dev, str) and dev
    buf = opencl.to_device(r.ctx, np.arange(4, dtype=np.float32))
    np.testing.assert_array_equal(opencl.read_back(r.queue, buf, (4,)), np.arange(4))
