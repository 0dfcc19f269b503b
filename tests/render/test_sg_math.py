"""The OpenCL headers (kernels/include/*.h) against sgpipe.core, the visibility decoder and
analytic answers: SG product / inner product / warp, f_h, cubemap and Γ_L pyramid lookups,
SSDF decoding, the microfacet factor M_o."""

import numpy as np
import pytest
from pyopencl import cltypes

from sg_testlib import SELFTEST_NV, f4, linear_env, run_kernel
from sgpipe.core import sg as csg
from sgpipe.core.fh import fh_hat_exact, fh_hemisphere, fh_hat_sigmoid
from sgpipe.core.maps import dir_to_cubemap
from sgpipe.render.headers import fh_coefficients

pytestmark = pytest.mark.opencl
RNG = np.random.default_rng(7)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_sg_product_inner_warp_match_core():
    n = 64
    p1, p2, o = _unit(RNG.normal(size=(n, 3))), _unit(RNG.normal(size=(n, 3))), \
        _unit(RNG.normal(size=(n, 3)) + [0, 0, 2])
    l1, l2 = np.exp(RNG.uniform(-1, 6, n)), np.exp(RNG.uniform(-1, 6, n))
    m1, m2 = RNG.uniform(0.1, 2, (n, 3)), RNG.uniform(0.1, 2, (n, 3))
    a = np.concatenate([p1, l1[:, None], m1, np.zeros((n, 1))], 1).astype(np.float32)
    b = np.concatenate([p2, l2[:, None], m2, np.zeros((n, 1))], 1).astype(np.float32)
    prod, inner, warp = run_kernel("t_sg", n, [a, b, f4(o)],
                                   [((n, 8), np.float32), ((n, 4), np.float32),
                                    ((n, 8), np.float32)])
    ax, lam, mu = csg.sg_product(p1, l1, m1, p2, l2, m2)
    np.testing.assert_allclose(prod[:, :3], ax, atol=2e-5)
    np.testing.assert_allclose(prod[:, 3], lam, rtol=2e-5)
    np.testing.assert_allclose(prod[:, 4:7], mu, rtol=1e-3, atol=1e-30)
    np.testing.assert_allclose(inner[:, :3], csg.sg_inner(p1, l1, m1, p2, l2, m2), rtol=1e-3,
                               atol=1e-30)  # float32 underflows below ~1e-38
    wp, wl, wm = csg.sg_warp(p1, l1, m1, o)
    np.testing.assert_allclose(warp[:, :3], wp, atol=1e-4)
    np.testing.assert_allclose(warp[:, 3], wl, rtol=1e-4)
    np.testing.assert_allclose(warp[:, 4:7], wm, rtol=1e-6)


def test_sg_product_and_inner_keep_their_precision_at_large_sharpness():
    """λ up to 1e9 (a warped lobe at a grazing view) with axes 0–30 lobe widths apart: the
    exponent d − λ1 − λ2 in float32 through −λ1λ2‖p1 − p2‖²/(λ1 + λ2 + d) stays within 1e-3 of
    float64 (the plain difference errs by ±100 there and overflows e^{…})."""
    n = 48
    l1 = np.exp(RNG.uniform(np.log(1e4), np.log(1e9), n))
    l2 = np.exp(RNG.uniform(np.log(1e2), np.log(1e6), n))
    p1 = _unit(RNG.normal(size=(n, 3)) + [0, 0, 4])
    off = _unit(np.cross(p1, RNG.normal(size=(n, 3))))
    ang = RNG.uniform(0, 5, n) / np.sqrt(np.minimum(l1, l2))      # up to 5 widths apart
    p2 = _unit(p1 + np.tan(ang)[:, None] * off)
    m1, m2 = np.ones((n, 3)), np.ones((n, 3))
    a = np.concatenate([p1, l1[:, None], m1, np.zeros((n, 1))], 1).astype(np.float32)
    b = np.concatenate([p2, l2[:, None], m2, np.zeros((n, 1))], 1).astype(np.float32)
    prod, inner, _ = run_kernel("t_sg", n, [a, b, f4(p1)],
                                [((n, 8), np.float32), ((n, 4), np.float32),
                                 ((n, 8), np.float32)])
    # float64 truth from the float32 axes the kernel saw, as the directions they stand for
    # (their float32 norms differ from 1 by ~6e-8: λ‖p‖ alone would move e^{…} by e^{±60})
    q1, q2 = _unit(a[:, :3].astype(float)), _unit(b[:, :3].astype(float))
    k1, k2 = a[:, 3].astype(float), b[:, 3].astype(float)
    _, _, mu = csg.sg_product(q1, k1, m1, q2, k2, m2)
    assert np.all(np.isfinite(prod[:, 4:7])) and np.all(np.isfinite(inner[:, :3]))
    np.testing.assert_allclose(prod[:, 4], mu[:, 0], rtol=1e-3, atol=1e-30)
    np.testing.assert_allclose(inner[:, 0], csg.sg_inner(q1, k1, m1, q2, k2, m2)[:, 0],
                               rtol=1e-3, atol=1e-30)


def test_fh_sigmoid_is_normalised_fit_and_close_to_exact():
    th = np.linspace(-np.pi / 2, np.pi / 2, 41)
    lam = np.array([1.0, 2.133, 5.0, 20.0, 100.0])
    T, L = np.meshgrid(th, lam)
    x = np.stack([T.ravel(), L.ravel()], -1).astype(np.float32)
    (out,) = run_kernel("t_fh", len(x), [x], [((len(x), 4), np.float32)])
    c = fh_coefficients()
    expect = np.maximum(fh_hat_sigmoid(x[:, 0], x[:, 1], c)
                        / fh_hat_sigmoid(np.pi / 2, x[:, 1], c), 0.0)   # negative tail clipped
    np.testing.assert_allclose(out[:, 0], expect, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(out[:, 1], fh_hemisphere(x[:, 1]), rtol=1e-5)
    top = np.isclose(x[:, 0], np.pi / 2)
    np.testing.assert_allclose(out[top, 0], 1.0, atol=1e-5)          # eq 46: f̂_h(π/2) = 1
    # The sigmoid's shape cannot follow broad lobes (λ ≈ 1: f̂_h(−π/2) = e^{−λ} ≠ 0), which is
    # why the renderer defaults to the exact table (next test).
    err = np.abs(out[:, 0] - fh_hat_exact(x[:, 0], x[:, 1]))
    assert err[x[:, 1] == 1.0].max() > 0.1
    A = 1 / np.tanh(x[:, 1]) - 1 / x[:, 1]
    np.testing.assert_allclose(out[:, 2], A, rtol=1e-4)


def test_fh_table_mode_matches_exact_integral():
    from sg_testlib import run_kernel_table
    th = np.linspace(-np.pi / 2, np.pi / 2, 37)
    lam = np.exp(np.linspace(np.log(0.02), np.log(5e4), 23))
    T, L = np.meshgrid(th, lam)
    x = np.stack([T.ravel(), L.ravel()], -1).astype(np.float32)
    (out,) = run_kernel_table("t_fh", len(x), [x], [((len(x), 4), np.float32)])
    exact = fh_hat_exact(x[:, 0].astype(float), x[:, 1].astype(float))
    assert np.abs(out[:, 0] - exact).max() < 5e-3
    assert np.abs(out[:, 0] - exact).mean() < 5e-4


def test_cubemap_bilinear_mip_and_lod():
    env, f = linear_env(face_res=16)
    n = 500
    d = _unit(RNG.normal(size=(n, 3)))
    lods = RNG.uniform(0, 4, n).astype(np.float32)
    ch = env.mip
    bil, tri, fst = run_kernel(
        "t_cube", n, [ch.texels, ch.offsets, ch.res, np.int32(len(ch.res)), f4(d), lods,
                      np.int32(0)],
        [((n, 4), np.float32)] * 3)
    face, s, t = dir_to_cubemap(d)
    np.testing.assert_array_equal(fst[:, 0].astype(int), face)
    np.testing.assert_allclose(fst[:, 1], s, atol=1e-5)
    np.testing.assert_allclose(fst[:, 2], t, atol=1e-5)
    # Bilinear on the face plane of a function linear in the unit direction: O(1/n²) error,
    # seamless across faces thanks to the border.
    np.testing.assert_allclose(bil[:, 0], f(d), atol=3e-3)
    from sg_testlib import cube_bilinear_np
    lo = np.floor(lods).astype(int)
    levels = np.stack([cube_bilinear_np(ch, k, d) for k in range(len(ch.res))])
    fr = (lods - lo)[:, None]
    idx = np.arange(n)
    expect = (1 - fr) * levels[lo, idx] + fr * levels[np.minimum(lo + 1, len(ch.res) - 1), idx]
    np.testing.assert_allclose(tri[:, :3], expect, rtol=1e-5, atol=1e-5)
    # Töral19 eq 8–10 with the cube distortion 4 max|d|³ / N²
    ma = np.abs(d).max(1)
    lod = 0.5 * np.log2((-2 * np.pi * np.log(0.1) / lods) / (4 * ma ** 3 / 16 ** 2))
    np.testing.assert_allclose(fst[:, 3], lod, atol=1e-4)


def test_gamma_pyramid_matches_exact_convolution_of_linear_env():
    env, _ = linear_env(face_res=32)
    g = np.array([0.5, 0.3, -0.2])
    n = 400
    d = _unit(RNG.normal(size=(n, 3)))
    lam = np.exp(RNG.uniform(np.log(0.05), np.log(2000.0), n)).astype(np.float32)
    (out,) = run_kernel("t_gamma", n, [env.pyramid.texels, env.pyramid.offsets, env.pyramid.res,
                                      env.lambdas, np.int32(len(env.lambdas)),
                                      np.float32(env.log_ratio),
                                      cltypes.make_float4(*env.mean, 0.0), f4(d), lam],
                        [((n, 4), np.float32)])
    # numpy port of the envmap contract's interpolation rule on the same levels
    from sg_testlib import cube_bilinear_np
    A = lambda x: np.where(x < 1e-3, x / 3, 1 / np.tanh(x) - 1 / np.maximum(x, 1e-30))
    lv = np.stack([cube_bilinear_np(env.pyramid, k, d)[:, 0] for k in range(len(env.lambdas))])
    L = env.lambdas.astype(float)
    lam64 = lam.astype(float)
    x = np.log(L[0] / lam64) / env.log_ratio
    k = np.clip(np.floor(x).astype(int), 0, len(L) - 2)
    w = np.clip(x - k, 0, 1)
    idx = np.arange(n)
    mid = (1 - w) * lv[k, idx] + w * lv[k + 1, idx]
    low = 1.0 + A(lam64) / A(L[-1]) * (lv[-1] - 1.0)
    V = np.where(lam64 >= L[0], lv[0], np.where(lam64 >= L[-1], mid, low))
    np.testing.assert_allclose(out[:, 0], V * csg.sg_integral(lam64, 1.0), rtol=2e-4)
    # and the physics: close to the exact convolution c0 + A(λ) g·p (coarse levels, ratio 2)
    exact = (1.0 + A(np.minimum(lam64, L[0])) * (d @ g)) * csg.sg_integral(lam64, 1.0)
    assert np.median(np.abs(out[:, 0] / exact - 1)) < 5e-3


@pytest.mark.parametrize("nv", [SELFTEST_NV, 8, 48])
def test_ssdf_decode_matches_visibility_reference(nv):
    """θ_d and the concentric-square map against sgpipe.visibility.decode, for term counts
    that take each of the decode's vector widths (ssdf.h SSDF_VW 4, 8, 16); directions on the
    axes, the square's diagonals and the octant boundaries of disk_to_square included."""
    decode = pytest.importorskip("sgpipe.visibility.decode")
    R = 8
    mean = RNG.normal(size=(R, R)).astype(np.float32)
    basis = RNG.normal(size=(nv, R, R)).astype(np.float32)
    w = (RNG.normal(size=nv) / np.sqrt(nv / 4)).astype(np.float32)
    n = 400
    d = _unit(RNG.normal(size=(n, 3)))
    d[:9] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0.6, 0.8, 0], [0, 0.6, -0.8], [0.5, 0.5, 0.7],
             [-0.5, 0.5, 0.7], [0, -0.05, 1], [-0.3, 0, 0.9]]
    d = _unit(d)
    data = np.moveaxis(basis, 0, -1).copy()
    (out,) = run_kernel("t_ssdf", n, [data, mean, np.int32(R), w, np.int32(1), f4(d)],
                        [((n, 4), np.float32)], nv=nv)
    ref = decode.decode_ssdf_local(d, w, mean, basis, max_distance=np.inf)
    np.testing.assert_allclose(out[:, 0], ref, atol=2e-4)
    from sgpipe.core.sphere import hemisphere_to_concentric_square
    up = d[:, 2] >= 0
    u, v = hemisphere_to_concentric_square(d[up].astype(np.float64))
    np.testing.assert_allclose(out[up, 1], u, atol=2e-6)
    np.testing.assert_allclose(out[up, 2], v, atol=2e-6)
    # Without data: the tangent plane alone, θ_d = elevation.
    (bare,) = run_kernel("t_ssdf", n, [data, mean, np.int32(R), w, np.int32(0), f4(d)],
                         [((n, 4), np.float32)], nv=nv)
    np.testing.assert_allclose(bare[:, 0], np.arcsin(d[:, 2]), atol=1e-5)


@pytest.mark.parametrize("model,params", [
    ("ggx", {"alpha_u": 0.2, "alpha_v": 0.4, "kd": 0.3, "ks": 0.7}),
    ("cook_torrance", {"m": 0.3, "ks": 0.6}),
    ("ashikhmin_shirley", {"nu": 50, "nv": 200, "rd": 0.4, "rs": 0.05}),
    ("beckmann", {"alpha": 0.3, "ks": 0.5, "fresnel": "conductor"}),
    ("ward", {"alpha": 0.15, "kd": 0.2}),
    ("gltf_pbr", {"base_color": [0.8, 0.5, 0.3], "metallic": 0.4, "roughness": 0.35,
                  "anisotropy": 0.5}),
])
def test_microfacet_factor_matches_brdf_package(model, params):
    brdf_mod = pytest.importorskip("sgpipe.brdf")
    from sgpipe.render.materials import Material, pack_materials
    b = brdf_mod.make_brdf(model, params)
    tab = pack_materials([Material.from_brdf("m", b)])
    n = 200
    o = _unit(RNG.normal(size=(n, 3)) * [1, 1, 0.5] + [0, 0, 0.8])
    i = _unit(RNG.normal(size=(n, 3)) * [1, 1, 0.5] + [0, 0, 0.8])
    mo, fd = run_kernel("t_brdf", n, [tab.records[0], tab.tables, f4(o), f4(i)],
                        [((n, 4), np.float32)] * 2)
    np.testing.assert_allclose(mo[:, :3], b.remaining_factor(o, i), rtol=2e-3, atol=1e-6)
    np.testing.assert_allclose(fd[:, :3], b.diffuse(o, i), rtol=1e-4, atol=1e-7)


def test_lookups_agree_with_envmap_python_readers(tmp_path):
    """OpenCL Γ_L and MIP lookups vs sgpipe.envmap's reference readers, on folders written by
    the real environment stage: the cheap border-1 level path (`gamma_lookup` vs
    `lookup_simple`); the accurate path `sg` uses is tested in test_gamma_lookup_cl.py."""
    from sg_testlib import latlong_dirs_and_weights
    from sgpipe import envmap
    from sgpipe.config import load_config
    from sgpipe.io import write_exr
    from sgpipe.render.envdata import EnvData
    from sgpipe.stages import envmap as envmap_stage
    d, _ = latlong_dirs_and_weights(16, 32)
    sky = (0.4 + 0.3 * d[..., 1:2] + 3.0 * np.exp(8.0 * (d @ [0.6, 0.64, 0.48] - 1))[..., None]
           * np.array([1.0, 0.8, 0.6])).astype(np.float32)
    write_exr(tmp_path / "sky.exr", sky)
    (tmp_path / "c.yaml").write_text("envmap: {environment: sky.exr, cube_resolution: 8}\n")
    envmap_stage.run(load_config(tmp_path / "c.yaml"), tmp_path / "out")
    tmp_path = tmp_path / "out" / "envmap"
    env = EnvData.load(tmp_path)
    n = 200
    dirs = _unit(RNG.normal(size=(n, 3)))
    lam = np.exp(RNG.uniform(np.log(0.1), np.log(100.0), n)).astype(np.float32)
    (out,) = run_kernel("t_gamma", n, [env.pyramid.texels, env.pyramid.offsets, env.pyramid.res,
                                      env.lambdas, np.int32(len(env.lambdas)),
                                      np.float32(env.log_ratio),
                                      cltypes.make_float4(*env.mean, 0.0), f4(dirs), lam],
                        [((n, 4), np.float32)])
    pyr = envmap.load_pyramid(tmp_path)
    expect = np.asarray(pyr.lookup_simple(dirs, lam.astype(float)), float)
    np.testing.assert_allclose(out[:, :3], expect, rtol=2e-3, atol=1e-5)
    lods = RNG.uniform(0, 3, n).astype(np.float32)
    ch = env.mip
    _, tri, _ = run_kernel("t_cube", n, [ch.texels, ch.offsets, ch.res, np.int32(len(ch.res)),
                                         f4(dirs), lods, np.int32(0)],
                           [((n, 4), np.float32)] * 3)
    mip = envmap.load_mip_chain(tmp_path)
    np.testing.assert_allclose(tri[:, :3], np.asarray(mip.lookup(dirs, lods.astype(float))),
                               rtol=2e-3, atol=1e-5)


def test_fast_math_paths_match_the_functions():
    """The kernels' shortcuts for the library's sin/cos/tan (polynomials on |x| ≤ π/4),
    ½ erfc (0 and 1 where float32 rounds to them), sinhc and A(λ) (λ ≥ 9: e^{−2λ} dropped)
    against float64, on both sides of every switch-over."""
    from scipy.special import erfc
    edges = np.array([np.pi / 4, -np.pi / 4, -4.0, 10.5, 9.0, 1e-4, 1e-3], np.float32)
    x = np.concatenate([np.linspace(-12, 40, 4001, dtype=np.float32),
                        *[np.nextafter(e, np.float32([-1, 1])[:, None]).ravel() for e in edges],
                        edges])
    (out,) = run_kernel("t_fastmath", len(x), [x.astype(np.float32)],
                        [((len(x), 8), np.float32)])
    x64 = x.astype(np.float64)
    np.testing.assert_allclose(out[:, 0], np.sin(x64), rtol=3e-7, atol=3e-7)
    np.testing.assert_allclose(out[:, 1], np.cos(x64), rtol=3e-7, atol=3e-7)
    small = np.abs(x64) <= 1.5
    np.testing.assert_allclose(out[small, 2], np.tan(x64[small]), rtol=5e-7, atol=1e-7)
    np.testing.assert_allclose(out[:, 3], 0.5 * erfc(x64), rtol=2e-6, atol=3e-8)
    pos = x64 > 0
    sinhc = -np.expm1(-2 * x64[pos]) / x64[pos]
    np.testing.assert_allclose(out[pos, 4], sinhc, rtol=3e-7)
    far = x64 >= 1.0          # (below, coth λ − 1/λ cancels in float32 either way)
    A = 1 / np.tanh(x64[far]) - 1 / x64[far]
    np.testing.assert_allclose(out[far, 5], A, rtol=1e-6)
