"""`gmm_toral19`, Töral19 §IV–V as published: the nearest fitted view's lobes as fitted, each
looked up once in the dual-paraboloid MIP chain at the eq 10 level with eq 11's distortion —
pinned pixel by pixel to that formula written out with numpy (sgpipe.envmap.mip.MipChain "dp");
every improvement given back is `gmm`; each one matters; the fit stage writes the paper's
8-lobe independent fit; the dual paraboloid follows render.environment_rotation."""

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sgpipe.core.maps import cubemap_texel_dirs
from sgpipe.envmap import mip
from sgpipe.envmap.maps import cubemap_to_dual_paraboloid
from sgpipe.render.envdata import CubeChain, DpChain, EnvData
from sgpipe.render.materials import Material, pack_materials
from sgpipe.render.methods import METHODS, TORAL19_SWITCHES
from sgpipe.render.records import KernelFlag
from sgpipe.render.renderer import Frame, ObjectShading, Renderer
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject, trace_gbuffer

sys.path.insert(0, str(Path(__file__).parents[1] / "envmap"))
from envmap_helpers import spot_env  # noqa: E402

pytestmark = pytest.mark.opencl

B_DP = 1.2


def _unit(a):
    a = np.asarray(a, float)
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def _env(face_res=32, spike=True):
    """A structured map (spots) with, optionally, one bright texel in the point set and the map
    without it as `raw` (what the envmap stage writes), so `points` is live."""
    faces = spot_env(face_res).astype(np.float64)
    base = faces.copy()
    pts, energy = np.zeros((0, 3)), np.zeros((0, 3))
    if spike:
        f, i, j = 2, face_res // 3, face_res // 2
        faces[f, i, j] += 400.0
        pts = cubemap_texel_dirs(face_res)[f, i, j][None]
        om = mip.cube_distortion(pts) / face_res ** 2
        energy = np.full((1, 3), 400.0) * om[:, None]
    chain = mip.build_cube_chain(faces)
    raw = mip.build_cube_chain(base).levels[:1]
    env = EnvData.constant(0.0, face_res)
    dp = mip.build_dp_chain(cubemap_to_dual_paraboloid(faces, face_res, B_DP), B_DP)
    return replace(env, mip=CubeChain.from_levels(chain.levels), raw=CubeChain.from_levels(raw),
                   point_dirs=pts.astype(np.float32), point_energy=energy.astype(np.float32),
                   dp=DpChain.from_levels(dp.levels, B_DP)), dp


def _material(rng, nt=5, K=3, np_=1):
    m = Material("glossy", ks=np.ones(3), g_scale=1.0, diffuse=0, fresnel=0, shadowing=1)
    m.lobe_axis, m.lobe_lambda, m.lobe_mu = np.array([[0, 0, 1.0]]), np.array([40.0]), np.ones(1)
    theta = np.radians(np.linspace(0, 80, nt))
    J = nt * np_
    m.gmm = {"view_theta": theta, "view_phi": np.arange(np_) * 2 * np.pi / np_,
             "alpha": rng.uniform(0.05, 0.3, (J, K, 3)),
             "kappa": np.exp(rng.uniform(np.log(5.0), np.log(3000.0), (J, K))),
             "mu_theta": np.clip(np.repeat(theta, np_)[:, None] + rng.normal(0, 0.15, (J, K)),
                                 0, 1.5),
             "mu_phi": rng.normal(0, 0.3, (J, K)),
             "includes_diffuse": np.int32(0), "coherent": np.int32(0)}
    return m


def _sphere_frame(n=24):
    cam = Camera(eye=(0, 0.6, 4), target=(0, 0, 0), width=n, height=n, fov_deg=34)
    o, d = cam.rays()
    fr = Frame.from_gbuffer(trace_gbuffer([TraceObject.sphere("s", (0, 0, 0), 1.0)], o, d))
    return fr


def test_fixed_defines_are_the_papers():
    d = dict(METHODS["gmm_toral19"].fixed_defines)
    assert d == {"GMM_DP": 1, "GMM_TAPS": 1, "GMM_ROTATE": 0}
    assert METHODS["gmm_toral19"].kernel == METHODS["gmm"].kernel


def test_published_pixel_is_the_nearest_views_lobes_through_one_dp_lookup_each():
    """Eq 3 at the nearest fitted view, each lobe's axis turned into the pixel's frame, and eq
    6–11: Σ_k α_k · L̄_dp(μ_k; lod = ½ log2(Ω_s/Ω_p)), Ω_s = −2π ln(1 − 0.9)/κ_k,
    Ω_p = 4b²(|μ_z| + 1)²/n² — the numpy mirror MipChain("dp").lobe_lookup."""
    rng = np.random.default_rng(4)
    env, dp = _env(spike=False)
    m = _material(rng)
    fr = _sphere_frame()
    r = Renderer(env=env, materials=pack_materials([m]), objects=[ObjectShading(0)])
    got = r.shade("gmm_toral19", fr, flags=int(KernelFlag.NO_VISIBILITY)).astype(float)

    N, T = fr.normal[:, :3].astype(float), fr.tangent[:, :3].astype(float)
    Bv = np.cross(N, T)
    v = fr.view[:, :3].astype(float)
    o = _unit(np.stack([(v * T).sum(1), (v * Bv).sum(1), (v * N).sum(1)], -1))
    th = np.arccos(np.clip(o[:, 2], -1, 1))
    ph = np.arctan2(o[:, 1], o[:, 0])
    g = m.gmm
    nt = len(g["view_theta"])
    t = np.floor(np.clip(th / g["view_theta"][-1] * (nt - 1), 0, nt - 1) + 0.5).astype(int)
    want = np.zeros((len(o), 3))
    for k in range(g["alpha"].shape[1]):
        mt, phi = g["mu_theta"][t, k], ph + np.pi + g["mu_phi"][t, k]
        a = np.stack([np.sin(mt) * np.cos(phi), np.sin(mt) * np.sin(phi), np.cos(mt)], -1)
        w = _unit(a[:, :1] * T + a[:, 1:2] * Bv + a[:, 2:] * N)
        want += g["alpha"][t, k] * dp.lobe_lookup(w, g["kappa"][t, k], 0.9)
    np.testing.assert_allclose(got, want, rtol=3e-3, atol=1e-3 * np.abs(want).max())
    # the default gmm (16 taps on the cube chain, half-vector carry) differs
    ours = r.shade("gmm", fr, flags=int(KernelFlag.NO_VISIBILITY)).astype(float)
    assert np.abs(ours - want).max() > 0.02 * np.abs(want).max()


def test_every_improvement_given_back_is_gmm_and_each_one_matters():
    """render.gmm_toral19_adds with every TORAL19_SWITCHES entry binds and compiles exactly what
    `gmm` does: the same pixels; each entry given back alone (with cube_chain where it needs it)
    moves the image."""
    rng = np.random.default_rng(7)
    env, _ = _env()
    m = _material(rng, np_=4)
    pub = replace(m, gmm={**m.gmm, "alpha": m.gmm["alpha"][:, :2], "kappa": m.gmm["kappa"][:, :2],
                          "mu_theta": m.gmm["mu_theta"][:, :2], "mu_phi": m.gmm["mu_phi"][:, :2]})
    fr = _sphere_frame()
    kw = dict(env=env, materials=pack_materials([m]), objects=[ObjectShading(0)],
              materials_toral19=pack_materials([pub]))
    gmm = Renderer(**kw).shade("gmm", fr)
    full = Renderer(**kw, gmm_toral19_adds=tuple(TORAL19_SWITCHES)).shade("gmm_toral19", fr)
    np.testing.assert_array_equal(full, gmm)
    base = Renderer(**kw, gmm_toral19_adds=("cube_chain",)).shade("gmm_toral19", fr)
    assert np.abs(base - Renderer(**kw).shade("gmm_toral19", fr)).max() > 1e-3 * np.abs(base).max()
    for name in TORAL19_SWITCHES:
        if name == "cube_chain":
            continue
        one = Renderer(**kw, gmm_toral19_adds=("cube_chain", name)).shade("gmm_toral19", fr)
        assert np.abs(one - base).max() > 1e-3 * np.abs(base).max(), name


def test_points_without_cube_chain_is_refused():
    from sgpipe.config.sections.render import RenderSection
    with pytest.raises(ValueError, match="points needs cube_chain"):
        RenderSection(gmm_toral19_adds=["points"]).validate()


def _dp_quarter_turn(dp: DpChain, R) -> DpChain:
    """The chain of the map turned by R (a quarter turn about +Z maps each paraboloid's texel
    grid onto itself): texel (h, i, j) of the result holds the source texel of the same
    hemisphere image whose direction is Rᵀ·d."""
    from sgpipe.core.maps import dual_paraboloid_texel_dirs
    levels = []
    for l, n in enumerate(dp.res):
        n = int(n)
        img = dp.texels[dp.offsets[l]:dp.offsets[l] + 2 * n * n, :3].reshape(n, 2 * n, 3)
        dirs = dual_paraboloid_texel_dirs(n, dp.b)            # (2, n, n, 3)
        out = np.empty_like(img)
        for h in range(2):
            src = dirs[h].reshape(-1, 3)
            want = dirs[h].reshape(-1, 3) @ R                   # Rᵀ d
            idx = np.argmin(((want[:, None, :] - src[None, :, :]) ** 2).sum(-1), axis=1)
            assert np.allclose(src[idx], want, atol=1e-6)
            half = img[:, h * n:(h + 1) * n].reshape(-1, 3)
            out[:, h * n:(h + 1) * n] = half[idx].reshape(n, n, 3)
        levels.append(out)
    return DpChain.from_levels(levels, dp.b)


def test_dual_paraboloid_follows_the_environment_rotation():
    """Rotation R in the kernel (dpmap.h through env_to_map) = no rotation with the chain's
    texels turned by R (a quarter turn about +Z: an exact permutation), to float rounding."""
    rng = np.random.default_rng(9)
    env, _ = _env(face_res=16, spike=False)
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    m = _material(rng)
    fr = _sphere_frame(16)
    kw = dict(materials=pack_materials([m]), objects=[ObjectShading(0)])
    r = Renderer(env=env, **kw)
    r.rotate_environment(R)
    got = r.shade("gmm_toral19", fr, flags=int(KernelFlag.NO_ENV_DIFFUSE))
    turned = replace(env, dp=_dp_quarter_turn(env.dp, R))
    want = Renderer(env=turned, **kw).shade("gmm_toral19", fr,
                                            flags=int(KernelFlag.NO_ENV_DIFFUSE))
    plain = Renderer(env=env, **kw).shade("gmm_toral19", fr,
                                          flags=int(KernelFlag.NO_ENV_DIFFUSE))
    scale = np.abs(want).max()
    assert np.abs(got - want).max() < 1e-4 * scale
    assert np.abs(plain - want).max() > 0.05 * scale


def test_dp_chain_from_cube_is_the_envmap_stages():
    """EnvData.dp_chain derived from a cube chain = the envmap stage's build (cubemap →
    paraboloids at the cube's resolution, b = 1.2, box MIP)."""
    faces = spot_env(16).astype(np.float64)
    want = mip.build_dp_chain(cubemap_to_dual_paraboloid(faces, 16, 1.2), 1.2)
    got = DpChain.from_cube(CubeChain.from_levels(mip.build_cube_chain(faces).levels))
    ref = DpChain.from_levels(want.levels, 1.2)
    np.testing.assert_allclose(got.texels, ref.texels, rtol=1e-5, atol=1e-6)


@pytest.mark.slow
def test_fit_stage_writes_the_published_mixtures_only_when_rendered(tmp_path):
    """With gmm_toral19 in render.methods `sgpipe fit` writes view_gmm_toral19.npz: 8 lobes per
    view (the tiny config's own fit has 4), independent views, the specular part; without it,
    no such file."""
    import subprocess
    import textwrap

    from sgpipe.artifacts.fit import read_view_gmm
    sys.path.insert(0, str(Path(__file__).parents[1]))
    from tiny_scene import tiny_config
    for methods, want in (("[gmm, gmm_toral19, reference]", True), ("[gmm, reference]", False)):
        cfg = tmp_path / f"tiny_{want}.yaml"
        cfg.write_text(textwrap.dedent(tiny_config(methods, workers=1)))
        out = tmp_path / f"out_{want}"
        r = subprocess.run([sys.executable, "-m", "sgpipe", "fit", str(cfg), "--out", str(out)],
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr
        folder = out / "fit" / "shiny"
        assert (folder / "view_gmm_toral19.npz").is_file() == want
        if want:
            pub = read_view_gmm(folder, "shiny", name="view_gmm_toral19.npz")
            own = read_view_gmm(folder, "shiny")
            assert pub["alpha"].shape[1] == 8 and own["alpha"].shape[1] == 4
            assert int(pub["coherent"]) == 0 and int(pub["includes_diffuse"]) == 0
            assert pub["alpha"].shape[0] == own["alpha"].shape[0]
