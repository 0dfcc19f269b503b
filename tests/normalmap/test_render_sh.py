"""The SH method `nm_sh` (Han07 §5, eq 12) and the engine bake `engine_bake` in the kernels:
nm_sh per pixel against numpy (the trilinear γ_lm of sgpipe.normalmap.sh's pyramid × the
BRDF's ρ̂_l, Lambert ρ̂ for the diffuse term, the cosine at the MIP normal); against the exact
average of the BRDF over a texel's normals (the ground truth of eq 4); engine_bake's
Blinn–Phong lobe (one vMF of κ(|n̄|), eq 20) against numpy, its baked per-texel |n̄|."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sgpipe.core.sh import sh_eval, sh_irradiance_coeffs
from sgpipe.normalmap.pyramid import mean_normal_pyramid
from sgpipe.normalmap.sh import ndf_sh_pyramid
from sgpipe.normalmap.vmf import bilinear
from sgpipe.render.envdata import EnvData
from sgpipe.render.materials import pack_materials
from sgpipe.render.normalmap_data import (BRDF_MODELS, NormalMapData, NormalMapPyramid,
                                          attach_normalmaps, specular_sh_coeffs)
from sgpipe.render.renderer import ObjectShading, Renderer
from tests.normalmap.render_mirror import (banerjee_kappa, blinn_lobe, directional, eq20_lobe,
                                           flat_frame, g1_beckmann, material,
                                           microfacet_lobe, renderer, single_lobe_pyramid,
                                           unit)

SIDE = 16
LIGHT = unit([0.35, -0.25, 0.9])


def _map(seed, spread=0.4):
    rng = np.random.default_rng(seed)
    n = np.concatenate([rng.normal(0, spread, (SIDE, SIDE, 2)), np.ones((SIDE, SIDE, 1))], -1)
    return unit(n)


def _sh_pyramid(normals, lmax):
    mean = [m.astype(np.float32) for m in mean_normal_pyramid(normals)]
    gamma = [g.astype(np.float32) for g in ndf_sh_pyramid(normals, lmax)]
    zeros = [np.zeros(m.shape[:2] + (0,), np.float32) for m in mean]
    return NormalMapPyramid(zeros, [z[..., None].repeat(3, -1) for z in zeros], mean, gamma)


def _trilinear(levels, u, v, lod):
    lod = min(max(lod, 0.0), len(levels) - 1.0)
    l0 = int(math.floor(lod))
    l1, f = min(l0 + 1, len(levels) - 1), lod - l0
    a = bilinear(levels[l0].astype(np.float64), u, v)
    return a * (1 - f) + (bilinear(levels[l1].astype(np.float64), u, v) * f if f > 0 else 0)


def _nm_sh_pixel(model, param, kd, ks, pyr, lmax, uv, lod, view, level0_taps=True):
    """numpy eq 12 for one pixel of the flat frame (n = z): diffuse Σ_{l≤2} Â_l γ_lm Y_lm(i),
    specular max(Σ_{l ≤ lmax} ρ̂_l γ_lm Y_lm(h), 0) with the model's other factors at n̄. Below
    lod 1, level 0's weight 1 − f is the bare material at the bilinear normal (a delta NDF) and
    γ_lm level 1's alone, weighted f; without `level0_taps` (nm_sh_han07) γ_lm are trilinear at
    every level."""
    lod = max(lod, 0.0)
    mean = _trilinear(pyr.mean, uv[0], uv[1], lod)
    if lod >= 1.0 or not level0_taps:
        g, base = _trilinear(pyr.gamma, uv[0], uv[1], lod), 0.0
    else:
        g = lod * bilinear(pyr.gamma[1].astype(np.float64), uv[0], uv[1])
        n0 = unit(bilinear(pyr.mean[0].astype(np.float64), uv[0], uv[1]))
        o, i = unit(view), LIGHT
        spec0 = (blinn_lobe(n0, o, i, param, (param + 2) / (8 * math.pi))
                 if model == "blinn_phong" else microfacet_lobe(model, param, 1.0, n0, o, i))
        base = (1 - lod) * (kd / math.pi * max(n0 @ i, 0.0) + ks * spec0)
    nbar = unit(mean)
    o = unit(view)
    i = LIGHT
    a = sh_irradiance_coeffs(2)
    yi = sh_eval(i, 2)
    diff = max(sum(a[l] * g[l * l:(l + 1) ** 2] @ yi[l * l:(l + 1) ** 2] for l in range(3)), 0.0)
    rho = specular_sh_coeffs(model, param, lmax)
    h = unit(o + i)
    yh = sh_eval(h, lmax)
    reff = max(sum(rho[l] * g[l * l:(l + 1) ** 2] @ yh[l * l:(l + 1) ** 2]
                   for l in range(lmax + 1)), 0.0)
    ci = nbar @ i
    spec = 0.0
    if ci > 0:
        if model == "blinn_phong":
            spec = reff * ci
        else:
            co = nbar @ o
            spec = g1_beckmann(co, param) * g1_beckmann(ci, param) * reff / co
    return base + kd / math.pi * diff + ks * spec


@pytest.mark.parametrize("model,param,lmax", [("blinn_phong", 12.0, 4), ("beckmann", 0.35, 6)])
def test_nm_sh_matches_numpy_eq12(model, param, lmax):
    normals = _map(1)
    pyr = _sh_pyramid(normals, lmax)
    n = 40
    rng = np.random.default_rng(2)
    uv = rng.uniform(0, 1, (n, 2))
    texels = 2.0 ** np.linspace(-1, 5, n)
    duv = np.zeros((n, 4))
    duv[:, 0] = texels / SIDE
    duv[:, 3] = 0.5 * duv[:, 0]
    th, ph = np.radians(rng.uniform(0, 60, n)), rng.uniform(-np.pi, np.pi, n)
    views = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    kd, ks = 0.4, 0.6
    rho = specular_sh_coeffs(model, param, lmax)
    img = renderer(model, param, pyr, kd=kd, ks=ks, lights=[directional(LIGHT)], rho=rho
                   ).shade("nm_sh", flat_frame(views, uv, duv))[:, 0]
    ref = np.array([_nm_sh_pixel(model, param, kd, ks, pyr, lmax, uv[k], math.log2(texels[k]),
                                 views[k]) for k in range(n)])
    assert ref.max() > 0.05
    np.testing.assert_allclose(img, ref, rtol=2e-3, atol=2e-4 * ref.max())


def _frame_cases(n, seed=2):
    rng = np.random.default_rng(seed)
    uv = rng.uniform(0, 1, (n, 2))
    texels = 2.0 ** np.linspace(-1, 5, n)
    duv = np.zeros((n, 4))
    duv[:, 0] = duv[:, 3] = texels / SIDE                 # square footprints: lod = log2 texels
    th, ph = np.radians(rng.uniform(0, 60, n)), rng.uniform(-np.pi, np.pi, n)
    views = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    return uv, texels, duv, views


@pytest.mark.parametrize("model,param,stored,lstar", [("blinn_phong", 9.0, 8, 6),
                                                      ("beckmann", 0.5, 8, 5),
                                                      ("blinn_phong", 60.0, 16, 16)])
def test_nm_sh_han07_truncates_eq12_at_sqrt_4s(model, param, stored, lstar):
    """nm_sh_han07 (§5 as published): eq 12 over bands l ≤ l* = ⌈√(4s)⌉ (Beckmann: s = 2/α² − 2)
    of a pyramid stored deeper, γ_lm trilinear at every level including level 0's Y_lm(n) —
    against numpy; `nm_sh` with the same pyramid uses every stored band (and differs). The
    s = 60 case stores l* = 16, the deepest pyramid the kernels take."""
    from sgpipe.render.normalmap_data import published_sh_order
    assert published_sh_order(model, param) == lstar
    pyr = _sh_pyramid(_map(3), stored)
    n = 32
    uv, texels, duv, views = _frame_cases(n)
    kd, ks = 0.3, 0.7
    rho = specular_sh_coeffs(model, param, 16)
    r = renderer(model, param, pyr, kd=kd, ks=ks, lights=[directional(LIGHT)], rho=rho)
    img = r.shade("nm_sh_han07", flat_frame(views, uv, duv))[:, 0]
    ref = np.array([_nm_sh_pixel(model, param, kd, ks, pyr, lstar, uv[k],
                                 math.log2(texels[k]), views[k], level0_taps=False)
                    for k in range(n)])
    assert ref.max() > 0.05
    np.testing.assert_allclose(img, ref, rtol=2e-3, atol=2e-4 * ref.max())
    if stored > lstar:
        full = r.shade("nm_sh", flat_frame(views, uv, duv))[:, 0]
        assert np.abs(full - img).max() > 1e-3 * ref.max()


def test_nm_sh_han07_adds_give_nm_sh_back():
    """All of render.nm_sh_han07_adds: nm_sh bit for bit (box footprint, level-0 taps, every
    band); each add alone changes the published image."""
    from sgpipe.render.methods import HAN07_SH_SWITCHES
    pyr = _sh_pyramid(_map(4), 8)
    uv, _, duv, views = _frame_cases(24, seed=6)
    rho = specular_sh_coeffs("blinn_phong", 9.0, 16)

    def shade(method, adds):
        r = renderer("blinn_phong", 9.0, pyr, kd=0.3, ks=0.7, lights=[directional(LIGHT)],
                     rho=rho, footprint="box", nm_sh_han07_adds=tuple(adds))
        return r.shade(method, flat_frame(views, uv, duv))

    published = shade("nm_sh_han07", ())
    np.testing.assert_array_equal(shade("nm_sh_han07", tuple(HAN07_SH_SWITCHES)),
                                  shade("nm_sh", ()))
    for name in HAN07_SH_SWITCHES:
        assert np.abs(shade("nm_sh_han07", (name,)) - published).max() > 1e-4, name


def test_nm_sh_lambert_converges_to_the_texel_average():
    """Lambert at the top level (one texel holding all 256 normals): eq 12 with l ≤ 2 against
    the exact mean of kd/π max(n·i, 0) over the normals (spread 0.4; measured −0.4 %, −1.8 %,
    +0.1 % for the three lights: the clamped cosine's l ≥ 3 terms, which Sec 5.2 drops)."""
    normals = _map(3)
    pyr = _sh_pyramid(normals, 2)
    n = 6
    rng = np.random.default_rng(4)
    lights = [unit([0.6, 0.1, 0.8]), unit([-0.2, 0.5, 0.5]), unit([0.9, 0.0, 0.3])]
    for i in lights:
        fr = flat_frame(np.tile([0, 0, 1.0], (n, 1)), rng.uniform(0, 1, (n, 2)),
                        np.tile([4.0, 0, 0, 4.0], (n, 1)))
        img = renderer("lambert", 1.0, pyr, kd=1.0, ks=0.0, lights=[directional(i)]
                       ).shade("nm_sh", fr)[:, 0]
        truth = np.mean(np.maximum(normals.reshape(-1, 3) @ i, 0)) / math.pi
        np.testing.assert_allclose(img, truth, rtol=0.03)


def test_engine_bake_blinn_phong_lobe():
    """engine_bake at the top level: one lobe about n̄/|n̄| with κ = κ(|n̄|) (Banerjee), eq 20;
    diffuse kd/π max(n̄·i, 0) at the normalised mean."""
    mu, kappa, s = unit([0.2, -0.1, 1.0]), 50.0, 80.0
    n = 8
    rng = np.random.default_rng(5)
    r = 2 * (LIGHT @ mu) * mu - LIGHT
    views = unit(r + rng.normal(0, 0.15, (n, 3)))
    fr = flat_frame(views, np.full((n, 2), 0.3), np.tile([8.0, 0, 0, 8.0], (n, 1)))
    img = renderer("blinn_phong", s, single_lobe_pyramid(mu, kappa), kd=0.2, ks=0.8,
                   lights=[directional(LIGHT)]).shade("engine_bake", fr)[:, 0]
    rl = 1 / math.tanh(kappa) - 1 / kappa
    sp, norm = eq20_lobe(s, banerjee_kappa(rl))
    ref = np.array([0.2 / math.pi * max(mu @ LIGHT, 0) + 0.8 * blinn_lobe(mu, o, LIGHT, sp, norm)
                    for o in views])
    np.testing.assert_allclose(img, ref, rtol=2e-3)


@pytest.mark.parametrize("method", ["engine_bake", "toksvig"])
def test_single_lobe_r_baked_or_per_fetch(method):
    """engine_bake's r is baked per texel (each texel's own |n̄|) and filtered like a
    roughness texture: between level-1 texels of different directions the trilinear mean of
    their lengths. toksvig's is computed per fetch (Toksvig 2005): the length of the trilinear
    mean, which the direction change shortens. Pixels between level 0 and 1 and between 1 and
    2 (lod 0.6 and 1.5) against numpy; the other method's r misses by more than 2 % (the test
    can tell them apart)."""
    normals = _map(7, spread=0.6)
    pyr = _sh_pyramid(normals, 2)
    lengths = [np.linalg.norm(m.astype(np.float64), axis=-1, keepdims=True) for m in pyr.mean]
    n, s, kd, ks = 12, 40.0, 0.1, 0.9
    rng = np.random.default_rng(8)
    uv = rng.uniform(0, 1, (n, 2))
    lods = np.where(np.arange(n) % 2 == 0, 0.6, 1.5)
    duv = np.stack([np.exp2(lods) / SIDE, np.zeros(n), np.zeros(n), np.exp2(lods) / SIDE], 1)
    views = unit(np.tile([0.1, 0.2, 1.0], (n, 1)) + rng.normal(0, 0.1, (n, 3)))
    img = renderer("blinn_phong", s, pyr, kd=kd, ks=ks, lights=[directional(LIGHT)]
                   ).shade(method, flat_frame(views, uv, duv))[:, 0]

    def lobe(r):
        if method == "engine_bake":
            return eq20_lobe(s, banerjee_kappa(min(r, 1 - 1e-7)))
        sp = s * r / (r + s * (1 - r))                  # Toksvig's exponent f·s
        return sp, (sp + 2) / (8 * math.pi)

    want, other = [], []
    for (u, v), lod, o in zip(uv, lods, views):
        mean = _trilinear(pyr.mean, u, v, lod)
        nbar = unit(mean)
        baked, fetched = _trilinear(lengths, u, v, lod)[0], np.linalg.norm(mean)
        for r, out in (((baked, want), (fetched, other)) if method == "engine_bake"
                       else ((fetched, want), (baked, other))):
            sp, norm = lobe(r)
            out.append(kd / math.pi * max(nbar @ LIGHT, 0)
                       + ks * blinn_lobe(nbar, o, LIGHT, sp, norm))
    np.testing.assert_allclose(img, want, rtol=3e-3)
    assert np.max(np.abs(np.array(other) / np.array(want) - 1)) > 0.02


def test_single_lobe_methods_between_level0_texels_are_the_bare_material():
    """Box footprint at level 0: every tap reads the baked r = 1 of level 0, so engine_bake
    and toksvig shade each tap's bilinear normal with the bare material, exactly as
    normals_mip does — the interpolated normal's shortening between two texels is not
    roughness (the reference reads the normalised bilinear normal; toksvig's per-fetch length
    would broaden the taps between texels, which the test catches)."""
    normals = _map(9, spread=0.8)
    pyr = _sh_pyramid(normals, 2)
    n, s = 16, 60.0
    rng = np.random.default_rng(10)
    uv = rng.uniform(0, 1, (n, 2))
    duv = np.tile([1.0 / SIDE, 0, 0, 1.0 / SIDE], (n, 1))
    views = unit(np.tile([0.0, 0.1, 1.0], (n, 1)) + rng.normal(0, 0.2, (n, 3)))
    out = {}
    for method in ("engine_bake", "normals_mip", "toksvig"):
        _, m = material("blinn_phong", s, 0.1, 0.9)
        r = Renderer(env=EnvData.constant(0.0), materials=pack_materials([m]),
                     objects=[ObjectShading(0, normal_map=-1)], lights=[directional(LIGHT)])
        attach_normalmaps(r, NormalMapData.pack([pyr], [s], 1, [BRDF_MODELS["blinn_phong"]],
                                                footprint="box").with_environment(None, False))
        out[method] = r.shade(method, flat_frame(views, uv, duv))[:, 0]
    for method in ("engine_bake", "toksvig"):
        np.testing.assert_allclose(out[method], out["normals_mip"], rtol=1e-5, atol=1e-7)
