"""Environment lighting of the normal-map kernels (nm_shade.h): the specular lobe of each vMF
lobe convolved with the BRDF (eq 20 / 21) warped to an SG in i-space and looked up in the Γ_L
pyramid (eq 24–26 with SG), checked under a constant environment against quadrature — the
directional albedo of the BRDF averaged over the vMF NDF; nm_sh's diffuse term Σ Â_l γ_lm L_lm
with γ rotated to world against the irradiance of the rotated normal (sgpipe.core.sh)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sgpipe.core.sh import sh_eval, sh_expand_bands, sh_irradiance_coeffs
from sgpipe.render.envdata import EnvData
from sgpipe.render.records import KernelFlag
from tests.normalmap.quadrature import frame as axis_frame
from tests.normalmap.quadrature import polar_rule
from tests.normalmap.render_mirror import (banerjee_kappa, flat_frame, material,
                                           normal_frames, renderer, single_lobe_pyramid, unit,
                                           vmf_pdf)

MU = unit([0.15, 0.1, 1.0])
C = 0.7          # constant radiance


def _albedo_table(brdf, cos_o):
    """∫ ρ(o, i) max(i·z, 0) di for views at cos θ_o (isotropic BRDF, z the normal)."""
    out = []
    d, w = polar_rule(200, 128, math.pi)
    for c in cos_o:
        o = np.array([math.sqrt(max(1 - c * c, 0.0)), 0.0, c])
        r = np.array([-o[0], 0.0, o[2]])                     # mirror direction about z
        i = d @ axis_frame(r).T
        f = brdf.eval(np.tile(o, (len(i), 1)), i)[:, 0] * np.maximum(i[:, 2], 0.0)
        out.append(float(np.sum(f * w)))
    return np.array(out)


def _truth(brdf, kappa, views, mu=MU):
    """C × E_vMF(n)[albedo(n·o)] by quadrature over the NDF (the reference's per-normal BRDF
    under a constant environment, nothing below a normal's horizon)."""
    cos_grid = np.linspace(0.02, 1.0, 50)
    table = _albedo_table(brdf, cos_grid)
    d, w = polar_rule(120, 64, min(math.pi, 12 / math.sqrt(kappa)))
    n = d @ axis_frame(mu).T
    pw = w * vmf_pdf(d[:, 2], kappa)
    out = []
    for o in views:
        co = n @ o
        out.append(C * float(np.sum(pw * np.where(co > 0.02, np.interp(co, cos_grid, table), 0))))
    return np.array(out)


@pytest.mark.parametrize("model,param,kappa,tol", [
    ("blinn_phong", 60.0, 100.0, 0.035), ("blinn_phong", 200.0, 40.0, 0.03),
    ("beckmann", 0.2, 100.0, 0.01), ("cook_torrance", 0.2, 100.0, 0.03),
    ("cook_torrance", 0.3, 30.0, 0.065), ("ggx", 0.1, 400.0, 0.015), ("ggx", 0.2, 100.0, 0.065),
    ("ggx", 0.3, 30.0, 0.18), ("ggx", 0.6, 30.0, 0.11), ("gltf_pbr", 0.2, 100.0, 0.065)])
def test_environment_specular_under_a_constant_environment(model, param, kappa, tol):
    """Per pixel relative error of `vmf` against the quadrature, views up to 40° from the lobe
    axis. Measured: Blinn–Phong s 60 κ 100 +1.7 … +2.4 %, s 200 κ 40 −2.0 … −0.6 %, Beckmann
    α 0.2 κ 100 −0.4 … +0.1 %, Cook–Torrance m 0.2 κ 100 +1.5 … +2.0 %, m 0.3 κ 30 +0.7 …
    +5.0 %; GGX (its NDF lobes convolved with the vMF through sg's specular, × the normals' mean
    albedo ratio) α 0.1 κ 400 −1.3 … −0.9 %, α 0.2 κ 100 −5.5 … −3.7 % (glTF the same), α 0.3
    κ 30 −16.4 … −11.8 %, α 0.6 κ 30 −9.9 … −7.8 % (one SG of GGX's mass at the peak-matched
    α′: +1.1, +5.7, +13.7, +52 % at worst)."""
    brdf, _ = material(model, param)
    rng = np.random.default_rng(7)
    n = 10
    th, ph = np.radians(rng.uniform(0, 40, n)), rng.uniform(-np.pi, np.pi, n)
    views = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    views = unit(views @ axis_frame(MU).T)
    duv = np.zeros((n, 4))
    duv[:, 0] = duv[:, 3] = 8.0
    fr = flat_frame(views, np.full((n, 2), 0.4), duv)
    r = renderer(model, param, single_lobe_pyramid(MU, kappa), env=EnvData.constant(C),
                 env_specular=True)
    img = r.shade("vmf", fr, flags=KernelFlag.NO_ENV_DIFFUSE)[:, 0]
    ref = _truth(brdf, kappa, views)
    assert ref.min() > 0.05
    err = np.abs(img / ref - 1)
    assert err.max() < tol, (err.max(), img, ref)


@pytest.mark.parametrize("model,param,tol,fresnel", [
    ("blinn_phong", 60.0, 0.085, "none"), ("beckmann", 0.15, 0.045, "none"),
    ("beckmann", 0.3, 0.055, "none"), ("cook_torrance", 0.2, 0.055, "none"),
    ("beckmann", 0.15, 0.075, "schlick"), ("beckmann", 0.3, 0.115, "schlick"),
    ("cook_torrance", 0.2, 0.145, "schlick")])
def test_environment_specular_at_grazing_views(model, param, tol, fresnel):
    """Views 40° … 87° from a sharp lobe (κ = 10⁵) about z under a constant environment: the
    lobe's mean factors (nm_env_factor: the cosine × Jacobian's second-order mean, the
    light-side masking and the Jacobian's o·h averaged over the lobe above the horizon,
    Schlick's Fresnel averaged over the reflected lobe) on three sub-lobes kept above the
    horizon. Measured at 40/60/70/75/80/84/87°: Blinn–Phong +3.1/+3.1/+4.2/+5.2/+6.3/+7.4/
    +8.0 %; Beckmann α 0.15 0.0/+0.2/+1.4/+3.3/+4.1/+2.8/−0.6 %, α 0.3 +0.3/+3.5/+4.7/+4.3/
    +2.5/+1.0/−0.9 %; Cook–Torrance m 0.2 +2.5/+3.6/+5.2/+5.1/+4.4/+3.5/+2.8 %; with Schlick
    (F0 0.04) Beckmann α 0.15 −0.5/−1.0/+1.9/+5.7/+7.2/+5.9/+2.1 %, α 0.3 −0.6/+7.1/+10.5/
    +10.0/+7.2/+4.5/+1.5 %, Cook–Torrance +1.6/+4.2/+8.3/+7.1/+2.5/−5.1/−14.1 %. One
    isotropic warped lobe, cut by the horizon a second time, erred up to 9.2 / 14.5 / 16.5 /
    13.6 / 12.2 / 14.3 / 27.8 % over the same views (at 84–87°); the factors at the axis alone
    −53 % (α 0.15) and −84 % (α 0.3) at 87°, Fresnel at the axis +83 % (α 0.3, 80°)."""
    brdf, _ = material(model, param, fresnel=fresnel)
    th = np.radians([40.0, 60.0, 70.0, 75.0, 80.0, 84.0, 87.0])
    views = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    n = len(views)
    fr = flat_frame(views, np.full((n, 2), 0.4), np.tile([8.0, 0, 0, 8.0], (n, 1)))
    z = np.array([0.0, 0.0, 1.0])
    r = renderer(model, param, single_lobe_pyramid(z, 1e5), env=EnvData.constant(C),
                 env_specular=True, fresnel=fresnel)
    img = r.shade("vmf", fr, flags=KernelFlag.NO_ENV_DIFFUSE)[:, 0]
    ref = _truth(brdf, 1e5, views, z)
    err = np.abs(img / ref - 1)
    assert err.max() < tol, (err, img, ref)


@pytest.mark.parametrize("model,alpha,kappa,tol", [
    ("ggx", 0.15, 1e5, 0.035), ("gltf_pbr", 0.15, 1e5, 0.045), ("ggx", 0.3, 1e5, 0.02),
    ("ggx", 0.3, 30.0, 0.26), ("ggx", 0.6, 20.0, 0.2), ("gltf_pbr", 0.6, 20.0, 0.21)])
def test_ggx_environment_specular_up_to_grazing(model, alpha, kappa, tol):
    """A GGX lobe about z under a constant environment, views 0°, 40°, 60°, 70°, 75°, 80°, 84°,
    87°. Sharp (κ = 10⁵): the material's NDF lobes, energy-scaled, within 0.1 % up to 84° and
    +3.1 % at 87° (α 0.15; glTF +4.1 %), +1.5 % (α 0.3) — one SG of GGX's mass lost its tail
    there, −41 % at 87°. Filtered, the lobes convolved with the vMF and × the normals' mean
    albedo over the axis': α 0.3 κ 30 −16/−13/−8/+1/+5/+11/+24/+22 %, α 0.6 κ 20
    −14/−11/−5/+1/−1/+5/−2/+17 % (glTF +19 % at 87°; the one SG: +14 … −16 % and +49 … −3 %,
    +22 % at 87°)."""
    brdf, _ = material(model, alpha)
    th = np.radians([0.0, 40.0, 60.0, 70.0, 75.0, 80.0, 84.0, 87.0])
    views = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    n = len(views)
    fr = flat_frame(views, np.full((n, 2), 0.4), np.tile([8.0, 0, 0, 8.0], (n, 1)))
    z = np.array([0.0, 0.0, 1.0])
    r = renderer(model, alpha, single_lobe_pyramid(z, kappa), env=EnvData.constant(C),
                 env_specular=True)
    img = r.shade("vmf", fr, flags=KernelFlag.NO_ENV_DIFFUSE)[:, 0]
    err = np.abs(img / _truth(brdf, kappa, views, z) - 1)
    assert err.max() < tol, err


def test_environment_specular_off_without_an_environment():
    """No environment (env flag 0): the Γ_L lookups are skipped, the specular is zero."""
    fr = flat_frame(unit([[0.1, 0.2, 1.0]]), [[0.4, 0.4]], [[8.0, 0, 0, 8.0]])
    r = renderer("blinn_phong", 60.0, single_lobe_pyramid(MU, 100.0),
                 env=EnvData.constant(C), env_specular=False)
    assert r.shade("vmf", fr, flags=KernelFlag.NO_ENV_DIFFUSE)[0, 0] == 0.0


def test_nm_sh_diffuse_environment_rotates_the_ndf_to_world():
    """A delta NDF at the tangent-space normal n (γ_lm = Y_lm(n)) on pixels with random frames:
    nm_sh's environment diffuse = kd/π Σ_{l ≤ 2} Â_l Y_lm(n_world) L_lm (the irradiance of the
    environment's SH at the world normal), L random."""
    rng = np.random.default_rng(11)
    nt = unit([0.3, -0.4, 1.0])
    gamma = sh_eval(nt, 2)
    light = rng.normal(0, 1, (9, 3))
    light[0] += 4.0
    n = 16
    N = unit(rng.normal(0, 1, (n, 3)))
    T, _ = normal_frames(N)
    B = np.cross(N, T)
    views = N                                                  # view along the normal
    fr = flat_frame(views, np.full((n, 2), 0.4), np.tile([8.0, 0, 0, 8.0], (n, 1)))
    fr.normal[:, :3], fr.tangent[:, :3] = N, T
    kd = 0.6
    r = renderer("lambert", 1.0, single_lobe_pyramid(nt, 1e4, sh=gamma), kd=kd, ks=0.0,
                 env_sh=light)
    img = r.shade("nm_sh", fr)
    nw = nt[0] * T + nt[1] * B + nt[2] * N
    irr = sh_eval(nw, 2) @ (sh_expand_bands(sh_irradiance_coeffs(2))[:, None] * light)
    np.testing.assert_allclose(img, kd / math.pi * np.maximum(irr, 0), rtol=2e-4,
                               atol=1e-5 * np.abs(irr).max())


@pytest.mark.parametrize("model", ["ggx", "gltf_pbr"])
@pytest.mark.parametrize("method", ["toksvig", "engine_bake", "normals_mip"])
def test_single_lobe_ggx_environment_is_the_widened_lobe(model, method):
    """The single-lobe baselines' GGX lobe under a constant environment at the top level (mean
    length r = A(30)) against quadrature over the vMF of the method's κ — toksvig r/(1 − r),
    engine_bake κ(r), normals_mip none: nm_spec_env's SG of the widened α′ within +7 %
    (measured +2.7 … +5.6 %), the plain MIP's bare lobe through sg's specular within 0.3 %. A
    constant environment checks the lobes' energy only: the bare material's lobe in place of
    the widened one gives the same albedo here (within 0.7 %)."""
    brdf, _ = material(model, 0.2)
    pyr = single_lobe_pyramid(MU, 30.0)
    r = float(np.linalg.norm(np.asarray(pyr.mean[-1], float).reshape(-1, 3)[0]))
    kappa = {"toksvig": r / (1 - r), "engine_bake": banerjee_kappa(r),
             "normals_mip": 1e5}[method]
    rng = np.random.default_rng(7)
    th, ph = np.radians(rng.uniform(0, 40, 8)), rng.uniform(-np.pi, np.pi, 8)
    views = unit(np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
                 @ axis_frame(MU).T)
    fr = flat_frame(views, np.full((8, 2), 0.4), np.tile([8.0, 0, 0, 8.0], (8, 1)))
    img = renderer(model, 0.2, pyr, env=EnvData.constant(C), env_specular=True).shade(
        method, fr, flags=KernelFlag.NO_ENV_DIFFUSE)[:, 0]
    err = img / _truth(brdf, kappa, views) - 1
    assert np.all((err > -0.01) & (err < 0.07)), err
