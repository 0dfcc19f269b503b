"""The kernels' restructured forms equal the plain ones they replace: the environment's diffuse
SG lights eight lobes a pass in float8 lanes (env_diffuse.h) against one lobe at a time
(ENV_DIFFUSE_PER_LOBE, sg_light_diffuse), on the bench's teapot + floor frame (48-term SSDF
data, a normal map on the floor, broad and sharp environment lobes, Lambert, Cook–Torrance and
glTF diffuse kinds), through `sg`, `fis` and `gmm`'s shared diffuse_env_sg."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from sgpipe.render.records import KernelFlag
from sgpipe.render.renderer import Frame, Light, ObjectShading, Renderer, Textures
from sgpipe.scene.gbuffer import Tracer

_FILE = Path(__file__).resolve().parents[2] / "benchmarks" / "_scenes.py"
_spec = importlib.util.spec_from_file_location("bench_scenes_lanes", _FILE)
S = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(S)         # benchmarks/ is not an installed package


class _Switched(Renderer):
    """A renderer whose programs compile with extra defines (the plain forms' switches)."""

    extra: dict = {}

    def defines(self, method):
        return {**super().defines(method), **self.extra}


def _scene(gltf):
    """(Renderer keywords, Frame): the bench's sg frame at 72², glTF-uniform or not."""
    r, objs, cam = S.teapot_scene(width=72, height=72, gltf=gltf)
    env = r.env
    env.light_lambda[:3] = [80.0, 900.0, 3e4]      # sharp lobes: the SHARP_LIGHT branch
    env.light_lambda[3] = 1e-3                      # and a near-constant one
    tex = Textures()
    yy, xx = np.mgrid[0:16, 0:16] / 16.0
    nmap = np.stack([0.5 + 0.3 * np.sin(6 * xx), 0.5 + 0.2 * np.cos(5 * yy),
                     np.full_like(xx, 0.85)], -1)
    objects = [ObjectShading(o.material, vis=o.vis, normal_map=tex.add(nmap) if k == 0 else -1)
               for k, o in enumerate(r.objects)]
    kw = dict(env=env, materials=r.materials, objects=objects, textures=tex,
              lights=[Light("point", (-2.0, 3.2, 1.6), (8, 8, 8), 0.05)])
    fr = Frame.from_gbuffer(Tracer(objs).trace(*cam.rays()))
    return kw, fr


@pytest.mark.parametrize("gltf", [None, "uniform"])
def test_env_diffuse_lanes_equal_per_lobe_sum(gltf):
    kw, fr = _scene(gltf)
    out = {}
    for per_lobe in (False, True):
        r = _Switched(**kw)
        r.extra = {"ENV_DIFFUSE_PER_LOBE": 1} if per_lobe else {}
        fdev = r.upload_frame(fr)
        out[per_lobe] = {
            ("sg", f): r.shade("sg", fdev, flags=f | KernelFlag.NO_ENV_SPECULAR)
            for f in (0, KernelFlag.NO_VISIBILITY)}
        out[per_lobe]["fis"] = r.shade("fis", fdev, flags=KernelFlag.NO_ENV_SPECULAR)
    for key, a in out[False].items():
        b = out[True][key]
        assert np.all(np.isfinite(a)) and np.abs(b).max() > 0.05, key
        np.testing.assert_allclose(a, b, rtol=2e-5, atol=2e-6 * np.abs(b).max(),
                                   err_msg=str(key))
