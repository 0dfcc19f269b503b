"""`vmf_han07`, Han07 §7–8 as published: §8's SH lighting (eq 25–26, l* = 8, the
reparameterised lighting L' on a 16 × 16 table of views; sgpipe/render/han07_env.py) checked
against quadrature, the kernel pinned to the formula, and `render.vmf_han07_adds` giving `vmf`
back switch by switch."""

from __future__ import annotations

import math

import numpy as np

from sgpipe.core.sh import sh_eval
from sgpipe.render import han07_env
from sgpipe.render.envdata import EnvData
from sgpipe.render.methods import HAN07_SWITCHES
from sgpipe.render.normalmap_data import NormalMapPyramid, specular_sh_coeffs
from sgpipe.render.records import KernelFlag
from tests.normalmap.quadrature import frame as axis_frame
from tests.normalmap.render_mirror import (flat_frame, rbar_of_kappa, renderer,
                                           single_lobe_pyramid, unit)

C = 0.7


def _sphere_rule(nt=240, nph=480):
    """Midpoint rule on the sphere: (dirs (N, 3), weights (N,))."""
    th = (np.arange(nt) + 0.5) * np.pi / nt
    ph = (np.arange(nph) + 0.5) * 2 * np.pi / nph
    t, p = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    w = (np.sin(t) * (np.pi / nt) * (2 * np.pi / nph)).reshape(-1)
    return d, w


def _sky(d):
    """A smooth, coloured, positive environment."""
    return np.stack([1.0 + 0.6 * d[:, 0] + 0.4 * d[:, 2] ** 2,
                     0.8 + 0.3 * d[:, 1] * d[:, 2], 0.5 + 0.45 * d[:, 2]], -1)


def test_eq26_with_the_reparameterised_lighting_equals_the_half_vector_integral():
    """B(μ) = Σ_l ρ̂_l Σ_m L'_lm(o) Y_lm(μ) against ∫ L(ω_i) f(μ · h) dω_i for a Blinn–Phong
    s = 4 lobe (its ρ̂_l beyond l = 8 are < 1e-4 of ρ̂_0) and a smooth sky; L'_00 = L_00 for
    every view (the projection counts each texel's energy once)."""
    d, w = _sphere_rule()
    lw = _sky(d) * w[:, None]
    s = 4.0
    rho = specular_sh_coeffs("blinn_phong", s, han07_env.LMAX)
    f = lambda u: (s + 2) / (8 * np.pi) * np.maximum(u, 0.0) ** s  # noqa: E731
    rng = np.random.default_rng(3)
    views = unit(rng.normal(size=(6, 3)))
    lp = han07_env.reparameterised_sh(d, lw, views)
    l00 = han07_env.radiance_sh(d, lw)[0]
    np.testing.assert_allclose(lp[:, 0], np.tile(l00, (len(views), 1)), rtol=1e-9)
    band = np.repeat(rho, 2 * np.arange(han07_env.LMAX + 1) + 1)
    for o, lpo in zip(views, lp):
        for mu in unit(np.vstack([o + 0.3 * rng.normal(size=3) for _ in range(3)])):
            b_sh = (band * sh_eval(mu, han07_env.LMAX)) @ lpo
            h = unit(d + o)
            b_quad = (f(h @ mu)[:, None] * lw).sum(0)
            np.testing.assert_allclose(b_sh, b_quad, rtol=2e-3)


def _renderer(model, param, pyr, *, kd=0.0, ks=1.0, env=None, footprint="trilinear",
              adds=(), lights=()):
    """render_mirror.renderer with the environment on, every ρ̂_l to l* = 8, vmf_han07's adds."""
    return renderer(model, param, pyr, kd=kd, ks=ks, lights=lights, env=env or EnvData.constant(C),
                    rho=specular_sh_coeffs(model, param, han07_env.LMAX), env_sh=np.zeros((9, 3)),
                    env_specular=True, footprint=footprint, vmf_han07_adds=tuple(adds))


def _views(n, axis, max_deg, seed=7):
    rng = np.random.default_rng(seed)
    th, ph = np.radians(rng.uniform(0, max_deg, n)), rng.uniform(-np.pi, np.pi, n)
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    return unit(v @ axis_frame(axis).T)


def _lprime_at(table, o):
    """The kernel's bilinear read of the L' table at the view o (map frame = world here)."""
    nv = han07_env.VIEWS
    th, ph = math.acos(np.clip(o[2], -1, 1)), math.atan2(o[1], o[0]) % (2 * math.pi)
    fi = min(max(th / math.pi * nv - 0.5, 0.0), nv - 1.0)
    fj = ph / (2 * math.pi) * nv - 0.5
    i0 = min(int(math.floor(fi)), nv - 1)
    i1, ti = min(i0 + 1, nv - 1), fi - i0
    j0f = math.floor(fj)
    tj, j0 = fj - j0f, int(j0f) % nv
    j1 = (j0 + 1) % nv
    k = han07_env.NCOEF

    def at(i, j):
        return table[k * (1 + i * nv + j):k * (2 + i * nv + j), :3].astype(float)

    return ((1 - ti) * (1 - tj) * at(i0, j0) + (1 - ti) * tj * at(i0, j1)
            + ti * (1 - tj) * at(i1, j0) + ti * tj * at(i1, j1))


def test_kernel_shades_eq26_per_lobe():
    """vmf_han07's environment specular of one vMF lobe (Blinn–Phong s 8, κ 50) is
    ks (μ·o) Σ_l ρ̂_l e^{−l²/2κ} Σ_m L'_lm(o) Y_lm(μ) (eq 19, 26) with L' read bilinearly between
    the table's views — computed here in float64 from the same table."""
    mu, kappa, s = unit([0.2, -0.1, 1.0]), 50.0, 8.0
    r = _renderer("blinn_phong", s, single_lobe_pyramid(mu, kappa))
    n = 12
    views = _views(n, mu, 60.0)
    duv = np.zeros((n, 4))
    duv[:, 0] = duv[:, 3] = 8.0
    img = r.shade("vmf_han07", flat_frame(views, np.full((n, 2), 0.4), duv),
                  flags=KernelFlag.NO_ENV_DIFFUSE)[:, :3]
    table = han07_env.environment_sh8(EnvData.constant(C))
    rho = specular_sh_coeffs("blinn_phong", s, han07_env.LMAX)
    l = np.arange(han07_env.LMAX + 1)
    band = np.repeat(rho * np.exp(-l * l / (2 * kappa)), 2 * l + 1)
    # the lobe as the kernel recovers it from α·r (float32 texels)
    mu32 = unit(np.asarray(rbar_of_kappa(kappa) * mu, np.float32).astype(float))
    want = np.array([max(o @ mu32, 0.0) * np.maximum((band * sh_eval(mu32, 8)) @ _lprime_at(
        table, o), 0.0) for o in views])
    assert want.min() > 0.05
    np.testing.assert_allclose(img, want, rtol=2e-3)


def test_kernel_eq25_is_a_furnace():
    """Eq 25 under a constant environment: Lambert kd at any lobe and κ reflects kd·C (band 0's
    factor e^0 = 1; bands 1–2 of a constant map vanish)."""
    for mu, kappa in ((unit([0.0, 0.0, 1.0]), 1e4), (unit([0.5, 0.2, 1.0]), 3.0)):
        r = _renderer("lambert", 1.0, single_lobe_pyramid(mu, kappa), kd=0.5)
        n = 6
        views = _views(n, [0, 0, 1.0], 70.0)
        duv = np.zeros((n, 4))
        duv[:, 0] = duv[:, 3] = 8.0
        img = r.shade("vmf_han07", flat_frame(views, np.full((n, 2), 0.4), duv),
                      flags=KernelFlag.NO_ENV_SPECULAR)[:, :3]
        np.testing.assert_allclose(img, 0.5 * C, rtol=2e-3)


def _two_level_pyramid():
    """Level 0: 2×2 texels of four different normals (delta lobes) and colours (eq 22's
    features, kd and ks multipliers); level 1: their one-lobe vMF, mean normal, its length and
    mean colour — so that the trilinear blend, the box, level 0's taps, the environment paths
    and the lobes' colours all differ."""
    n0 = unit(np.array([[[0.5, 0.0, 1.0], [-0.3, 0.2, 1.0]], [[0.0, -0.6, 1.0], [0.1, 0.4, 1.0]]]))
    a0 = np.ones((2, 2, 1), np.float32)
    ar0 = n0[:, :, None, :].astype(np.float32)
    f0 = np.array([[[0.9, 0.2, 0.1, 1.0, 0.5, 0.5], [0.1, 0.3, 0.8, 0.2, 0.2, 0.3]],
                   [[0.5, 0.5, 0.5, 0.6, 0.9, 0.4], [0.2, 0.9, 0.2, 0.8, 0.8, 0.8]]])
    mean1 = n0.reshape(-1, 3).mean(0)
    a1 = np.ones((1, 1, 1), np.float32)
    ar1 = mean1.reshape(1, 1, 1, 3).astype(np.float32)
    af = [f0[:, :, None, :].astype(np.float32),
          f0.reshape(-1, 6).mean(0).reshape(1, 1, 1, 6).astype(np.float32)]
    return NormalMapPyramid([a0, a1], [ar0, ar1], [n0.astype(np.float32),
                                                   mean1.reshape(1, 1, 3).astype(np.float32)],
                            alpha_f=af)


def test_adds_give_vmf_back_one_switch_at_a_time():
    """All of render.vmf_han07_adds: vmf_han07 renders `vmf` bit for bit; each add alone changes
    the published image (a scene where every switch is exercised: the box footprint, level 0's
    taps at small footprints, the environment and a directional light)."""
    from sgpipe.render.renderer import Light
    pyr = _two_level_pyramid()
    n = 24
    rng = np.random.default_rng(5)
    views = _views(n, [0, 0, 1.0], 50.0, seed=2)
    uv = rng.uniform(0, 1, (n, 2))
    duv = np.zeros((n, 4))
    duv[:, 0] = duv[:, 3] = rng.uniform(0.2, 1.2, n)      # levels 0–1
    fr = flat_frame(views, uv, duv)

    def shade(method, adds):
        r = _renderer("beckmann", 0.15, pyr, kd=0.3, ks=0.6, footprint="box", adds=adds,
                      lights=[Light("directional", tuple(unit([0.3, 0.2, 1.0])), (1.0, 0.9, 0.8))])
        return r.shade(method, fr)

    base = shade("vmf", ())
    published = shade("vmf_han07", ())
    np.testing.assert_array_equal(shade("vmf_han07", tuple(HAN07_SWITCHES)), base)
    for name in HAN07_SWITCHES:
        one = shade("vmf_han07", (name,))
        assert np.abs(one - published).max() > 1e-4, name
