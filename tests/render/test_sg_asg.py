"""`sg` with ASG lobes (asg.h): the kernel's specular integral for one ASG against numerical
integration of ∫ L ρ max(0, n·i) di — under a linear environment (whose Γ_L is exact) for
several views, and on an anisotropic sphere under the studio map against texel quadrature —
and the lobe table's layout (SG lobes, header, ASG records) that fis keeps reading."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from sgpipe.render.materials import Material, pack_materials
from sgpipe.render.renderer import Frame, ObjectShading, Renderer

sys.path.insert(0, str(Path(__file__).parent))
from sg_testlib import linear_env  # noqa: E402

pytestmark = pytest.mark.opencl


def _asg_material(brdf, n_lobes=0):
    from sgpipe.fit.ndf_asg import ndf_asg
    fit, _ = ndf_asg(brdf.ndf_model, n_lobes)
    m = Material.from_brdf("a", brdf, lobes=[])
    m.set_asg(fit.z, fit.x, fit.sharpness_x, fit.sharpness_y, fit.amplitude)
    return m


def _frame(views, normal=(0, 0, 1.0), tangent=(1.0, 0, 0)):
    n = len(views)
    f4 = lambda a: np.concatenate([np.asarray(a, np.float32).reshape(-1, 3),
                                   np.zeros((n, 1), np.float32)], 1)
    return Frame(index=np.arange(n), shape=(1, n), normal=f4(np.tile(normal, (n, 1))),
                 tangent=f4(np.tile(tangent, (n, 1))), view=f4(views),
                 position=f4(np.zeros((n, 3))), uv=np.zeros((n, 2), np.float32),
                 obj=np.zeros(n, np.int32), tri=-np.ones(n, np.int32),
                 bary=np.zeros((n, 2), np.float32))


def _hemisphere(n=900):
    th = (np.arange(n) + 0.5) / n * np.pi / 2
    ph = (np.arange(4 * n) + 0.5) / (4 * n) * 2 * np.pi
    t, p = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    return d, (np.sin(t) * (np.pi / 2 / n) * (2 * np.pi / (4 * n))).ravel()


# measured relative errors over the five views: Beckmann (1 ASG) +1.0 … +2.4 %, GGX (3 ASGs)
# −0.3 … −2.5 % (M_o and the cosine taken at each sub-lobe's centre)
@pytest.mark.parametrize("model,params", [
    ("beckmann", {"alpha_u": 0.05, "alpha_v": 0.25, "ks": 1.0, "fresnel": "none"}),
    ("ggx", {"alpha_u": 0.3, "alpha_v": 0.06, "ks": 1.0, "fresnel": "schlick", "f0": 0.9})])
def test_specular_integral_under_linear_environment(model, params):
    brdf = pytest.importorskip("sgpipe.brdf")
    b = brdf.make_brdf(model, params)
    env, L = linear_env(c0=1.0, g=(0.3, 0.2, 0.5))
    r = Renderer(env=env, materials=pack_materials([_asg_material(b)]),
                 objects=[ObjectShading(0)])
    th, ph = np.radians([0, 30, 30, 60, 75]), np.radians([0, 0, 90, 45, 20])
    views = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    got = r.shade("sg", _frame(views))[:, 0].astype(float)
    d, w = _hemisphere()
    exact = np.array([np.sum(w * b.eval(np.broadcast_to(o, d.shape), d)[:, 0] * d[:, 2] * L(d))
                      for o in views])
    np.testing.assert_allclose(got, exact, rtol=0.035)


def _studio_env(N=64):
    envmap = pytest.importorskip("sgpipe.envmap")
    from sgpipe.envmap.maps import latlong_to_cubemap, read_environment
    from sgpipe.render.envdata import CubeChain, EnvData, GammaChain
    path = Path(__file__).resolve().parents[2] / "data_samples" / "studio.exr"
    cube = latlong_to_cubemap(read_environment(path), N)
    pyr = envmap.build_pyramid(cube)
    zero = np.zeros(3, np.float32)
    env = EnvData(pyramid=CubeChain.from_levels(pyr.samples),
                  lambdas=np.asarray(pyr.lambdas, np.float32), log_ratio=math.log(pyr.ratio),
                  mean=np.asarray(pyr.mean, np.float32), mip=CubeChain.constant(zero, 1, 1),
                  light_axes=np.array([[0.0, 1.0, 0.0]], np.float32),
                  light_lambda=np.array([1.0], np.float32), light_mu=np.zeros((1, 3), np.float32),
                  gamma=GammaChain.from_levels(pyr.values, pyr.slopes))
    return cube, env


def test_anisotropic_sphere_under_studio_matches_texel_quadrature():
    """Beckmann α 0.04 × 0.2 (5:1) sphere under studio.exr at cube 64 against the exact
    Σ_texels L Ω ρ max(0, n·i); measured: ASG 43.21 dB to the peak, bias +0.56 %; the 8
    free-axis SG lobes of `anisotropic: sg` 40.76 dB, bias −1.63 % (both floors fail)."""
    brdf = pytest.importorskip("sgpipe.brdf")
    from sgpipe.core.maps import cubemap_solid_angles, cubemap_texel_dirs
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import TraceObject, trace_gbuffer
    b = brdf.make_brdf("beckmann", {"alpha_u": 0.04, "alpha_v": 0.2, "ks": 1.0,
                                    "fresnel": "none"})
    cube, env = _studio_env()
    cam = Camera(eye=(0, 0.6, 4), target=(0, 0, 0), width=24, height=24, fov_deg=32)
    o, dirs = cam.rays()
    fr = Frame.from_gbuffer(trace_gbuffer([TraceObject.sphere("s", (0, 0, 0), 1.0)], o, dirs))
    r = Renderer(env=env, materials=pack_materials([_asg_material(b)]),
                 objects=[ObjectShading(0)])
    got = r.shade("sg", fr).astype(np.float64)
    N = cube.shape[1]
    src = cubemap_texel_dirs(N).reshape(-1, 3)
    E = (cube * cubemap_solid_angles(N)[..., None]).reshape(-1, 3)
    n, t = fr.normal[:, :3].astype(float), fr.tangent[:, :3].astype(float)
    bt, v = np.cross(n, t), fr.view[:, :3].astype(float)
    exact = np.zeros_like(got)
    for k in range(len(n)):
        frame = np.stack([t[k], bt[k], n[k]])
        il = src @ frame.T
        f = b.eval(np.broadcast_to(frame @ v[k], il.shape), il) * np.maximum(il[:, 2:3], 0)
        exact[k] = np.sum(f * E, 0)
    psnr = 10 * np.log10(np.max(exact) ** 2 / np.mean((got - exact) ** 2))
    bias = got.sum() / exact.sum() - 1
    print(f"psnr {psnr:.2f} bias {bias:+.4f}")
    assert psnr > 42.0 and abs(bias) < 0.015, (psnr, bias)


def test_lobe_table_keeps_sg_lobes_first():
    """Per material: its SG lobes (what fis samples), a header (…, n_asg), the ASG records
    (z, λ), (c, μ, φ, 0); a material without ASG gets a header with 0."""
    from sgpipe.core.asg import basis_around
    plain = Material("p", ks=np.ones(3), lobe_axis=np.array([[0, 0, 1.0]]),
                     lobe_lambda=np.array([50.0]), lobe_mu=np.array([1.0]))
    aniso = Material("a", ks=np.ones(3), lobe_axis=np.array([[0, 0, 1.0]] * 2),
                     lobe_lambda=np.array([50.0, 9.0]), lobe_mu=np.array([1.0, 0.2]))
    aniso.set_asg([[0, 0, 1.0]], [[0, 1.0, 0]], [400.0], [25.0], [0.9])
    t = pack_materials([plain, aniso])
    lobes = t.lobes
    assert lobes.shape == (1 + 1 + 2 + 1 + 1, 2, 4)
    assert t.records[1, 22] == 2 and t.records[1, 21] == 2     # LOBE0, NLOBES of "a"
    assert lobes[1, 1, 3] == 0 and lobes[4, 1, 3] == 1          # headers: 0 and 1 ASG
    z, lam = lobes[5, 0, :3], lobes[5, 0, 3]
    c, mu, phi = lobes[5, 1, :3]
    u, v = basis_around(z.astype(float))
    np.testing.assert_allclose(np.cos(phi) * u + np.sin(phi) * v, [0, 1, 0], atol=1e-6)
    assert (lam, mu, c) == pytest.approx((400.0, 25.0, 0.9))
