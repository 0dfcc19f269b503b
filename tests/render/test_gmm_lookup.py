"""The gmm kernel's per-lobe environment integral (gmm_shade.cl `gmm_lobe_integral`, Töral19
eq 6–10 on the box MIP chain, and with GMM_DP on the dual-paraboloid chain of eq 11) against its
numpy mirror `sgpipe.envmap.mip.MipChain.lobe_integral` / `lobe_lookup` (whose error vs
∫vMF(ω; μ, κ) L(ω) dω by quadrature is tested in tests/envmap/test_mip.py)."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "envmap"))
from envmap_helpers import spot_env  # noqa: E402  (the environment test_mip.py also uses)
from sgpipe.envmap import mip
from sgpipe.render import opencl
from sgpipe.envmap.maps import cubemap_to_dual_paraboloid
from sgpipe.render.envdata import CubeChain, DpChain

pytestmark = pytest.mark.opencl

# A few lines of test kernel around the real gmm_shade.cl (its helpers are inline functions).
_SRC = """#include "gmm_shade.cl"
__kernel void t_gmm_lobe(__global const float4 *mip, __global const int *off,
                         __global const int *res, const int nlev, const float b,
                         __global const float4 *q, __global float4 *out) {
    int i = get_global_id(0);
    out[i] = (float4)(gmm_lobe_integral(mip, off, res, nlev, q[i].xyz, q[i].w, 0.9f, b), 0.0f);
}
"""


def _lobe_kernel(taps: int, dp: bool = False):
    import pyopencl as cl

    from sgpipe.render.headers import fh_coefficients, layout_headers
    a, c3, c2, c1, c0 = fh_coefficients()
    d = {"NV": 4, "FH_A": a, "FH_C3": c3, "FH_C2": c2, "FH_C1": c1, "FH_C0": c0,
         "MAX_GMM_LOBES": 1, "GMM_TAPS": taps, "GMM_DP": int(dp)}
    ctx, queue = opencl.get_context()
    gen = opencl.generated_include_dir(layout_headers())
    opts = opencl.build_options(d, ("-I", str(opencl.kernel_dir()), "-I", str(gen)))
    prg = cl.Program(ctx, _SRC).build(options=list(opts))
    return ctx, queue, cl.Kernel(prg, "t_gmm_lobe")


def _kernel_lobe_integral(chain: mip.MipChain, dirs, kappa, taps: int = 16) -> np.ndarray:
    ctx, queue, kern = _lobe_kernel(taps, chain.kind == "dp")
    cc = (DpChain.from_levels(chain.levels, chain.b) if chain.kind == "dp"
          else CubeChain.from_levels(chain.levels))
    q = np.zeros((len(dirs), 4), np.float32)
    q[:, :3], q[:, 3] = dirs, kappa
    dev = lambda x, dt=np.float32: opencl.to_device(ctx, x, dtype=dt)
    out = opencl.empty_device(ctx, 16 * len(q))
    kern(queue, (len(q),), None, dev(cc.texels), dev(cc.offsets, np.int32),
         dev(cc.res, np.int32), np.int32(len(cc.res)), np.float32(chain.b), dev(q), out)
    return opencl.read_back(queue, out, (len(q), 4))[:, :3].astype(float)


def _unit(rng, n):
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("kind", ["cube", "dp"])
def test_kernel_lobe_integral_matches_numpy_mirror(kind):
    faces = spot_env(32)
    chain = (mip.build_cube_chain(faces) if kind == "cube"
             else mip.build_dp_chain(cubemap_to_dual_paraboloid(faces, 32, 1.2), 1.2))
    rng = np.random.default_rng(2)
    dirs = _unit(rng, 256)
    kappa = np.exp(rng.uniform(np.log(0.5), np.log(2e4), len(dirs)))
    got = _kernel_lobe_integral(chain, dirs, kappa)
    want = chain.lobe_integral(dirs, kappa)
    np.testing.assert_allclose(got, want, rtol=2e-3, atol=2e-3 * np.abs(want).mean())
    # GMM_TAPS = 1 is Töral19's single trilinear lookup at the eq 10 level (a = 0.9; with
    # the dual paraboloid, eq 11's distortion)
    one = _kernel_lobe_integral(chain, dirs, kappa, taps=1)
    np.testing.assert_allclose(one, chain.lobe_lookup(dirs, kappa, 0.9), rtol=2e-3,
                               atol=2e-3 * np.abs(want).mean())


def test_kernel_lobe_integral_of_constant_environment_is_exact():
    chain = mip.build_cube_chain(np.full((6, 16, 16, 3), 0.7))
    dirs = _unit(np.random.default_rng(3), 64)
    kappa = np.geomspace(0.1, 1e5, len(dirs))
    np.testing.assert_allclose(_kernel_lobe_integral(chain, dirs, kappa), 0.7, rtol=1e-5)
