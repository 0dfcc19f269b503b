"""render.normalmap_footprint = box (nm_shade_body.h): the pixel's box over the map — texels of
the chosen level weighted by their overlap with the footprint's u/v box, each texel's lobes
kept as they are — against numpy; and against the exact box average of the unfiltered map
(what the reference integrates) on a pixel grid that does not line up with the texel grid,
where trilinear's tent of about twice the pixel and its blend of unaligned lobes (eq 24) fall
behind."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sgpipe.normalmap.pyramid import mean_normal_pyramid
from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid
from sgpipe.render.envdata import EnvData
from sgpipe.render.materials import pack_materials
from sgpipe.render.normalmap_data import (BRDF_MODELS, NormalMapData, NormalMapPyramid,
                                          attach_normalmaps)
from sgpipe.render.renderer import ObjectShading, Renderer
from tests.normalmap.render_mirror import (blinn_lobe, directional, eq20_lobe, flat_frame,
                                           material, unit)

LIGHT = unit([0.3, -0.2, 0.9])
S = 60.0


def _renderer(pyr, footprint, *, kd, s=S, taps=1):
    _, m = material("blinn_phong", s, kd=kd, ks=1.0)
    r = Renderer(env=EnvData.constant(0.0), materials=pack_materials([m]),
                 objects=[ObjectShading(0, normal_map=-1)], lights=[directional(LIGHT)])
    attach_normalmaps(r, NormalMapData.pack([pyr], [s], taps, [BRDF_MODELS["blinn_phong"]],
                                            footprint=footprint).with_environment(None, False))
    return r


def _axis_overlap(c, w, m):
    """{texel (wrapped): overlap / w} of [c − w/2, c + w/2] over unit texels [k, k + 1)."""
    a, b = c - w / 2, c + w / 2
    out = {}
    for k in range(math.floor(a), math.ceil(b)):
        out[k % m] = out.get(k % m, 0.0) + (min(b, k + 1) - max(a, k)) / w
    return out


def _lobe_pyramid(rng, kappa):
    """Sides 8, 4, 2, 1; level 1's 16 texels each one vMF lobe (μ within ~25° of z, κ) with
    its exact mean A(κ)μ; the other levels flat (never read at these footprints)."""
    mus = unit(np.concatenate([rng.normal(0, 0.3, (4, 4, 2)), np.ones((4, 4, 1))], -1))
    rbar = 1.0 / math.tanh(kappa) - 1.0 / kappa          # A(κ) = r̄ of the lobe
    alpha, alpha_r, mean = [], [], []
    for m in (8, 4, 2, 1):
        a = np.ones((m, m, 1), np.float32)
        if m == 4:
            ar, mn = (rbar * mus)[:, :, None, :], rbar * mus
        else:
            ar = np.tile([0, 0, 1.0], (m, m, 1, 1))
            mn = np.tile([0, 0, 1.0], (m, m, 1))
        alpha.append(a)
        alpha_r.append(ar.astype(np.float32))
        mean.append(mn.astype(np.float32))
    return NormalMapPyramid(alpha, alpha_r, mean), mus, rbar


def test_box_weights_level_texels_by_overlap_and_keeps_their_lobes():
    """vmf, box footprint of 3.3 level-0 texels (> 9 texels at level 0 → level 1, ≤ 3 × 3):
    Σ_t overlap_t (Blinn–Phong eq 20 lobe of texel t + kd/π max(0, n̄·i)), n̄ = Σ_t overlap_t
    A(κ)μ_t, at axis-aligned and rotated footprints (RMS widths |∂u/∂(x, y)|, |∂v/∂(x, y)|),
    wrapping at the map's edge."""
    rng = np.random.default_rng(5)
    kappa, kd = 300.0, 0.2
    pyr, mus, rbar = _lobe_pyramid(rng, kappa)
    n = 24
    uv = rng.uniform(-1.0, 2.0, (n, 2))
    w = 3.3 / 8.0                                        # footprint in UV (level 0: 8 texels)
    ang = rng.uniform(0, 2 * math.pi, n)
    ang[: n // 2] = 0.0
    duv = np.stack([w * np.cos(ang), w * np.sin(ang), -w * np.sin(ang), w * np.cos(ang)], -1)
    mu = mus.reshape(-1, 3)[np.arange(n) % 16]            # views near some lobe's mirror
    views = unit(2 * (mu @ LIGHT)[:, None] * mu - LIGHT + rng.normal(0, 0.05, (n, 3)))
    img = _renderer(pyr, "box", kd=kd).shade("vmf", flat_frame(views, uv, duv))[:, 0]
    sp, norm = eq20_lobe(S, kappa)
    ref = np.zeros(n)
    for p in range(n):
        wu = math.hypot(duv[p, 0], duv[p, 2]) * 4           # level-1 texels
        wv = math.hypot(duv[p, 1], duv[p, 3]) * 4
        cu = (uv[p, 0] % 1.0) * 4
        cv = (1.0 - uv[p, 1] % 1.0) * 4                     # row 0 = v = 1
        nbar = np.zeros(3)
        for row, a in _axis_overlap(cv, wv, 4).items():
            for col, b in _axis_overlap(cu, wu, 4).items():
                ref[p] += a * b * blinn_lobe(mus[row, col], views[p], LIGHT, sp, norm)
                nbar += a * b * rbar * mus[row, col]
        ref[p] += kd / math.pi * max(nbar @ LIGHT, 0.0)
    assert ref.max() > 0.5
    np.testing.assert_allclose(img, ref, rtol=2e-4, atol=1e-5)
    tri = _renderer(pyr, "trilinear", kd=kd).shade("vmf", flat_frame(views, uv, duv))[:, 0]
    assert np.abs(tri - ref).max() > 0.05            # the check tells the two filters apart


def _grooves(side=128, period=64, tilt=35.0):
    """V-grooves along v and u: a wall tilted ±tilt over a quarter period each, flat between."""
    t = math.tan(math.radians(tilt))
    k = np.arange(side) % period
    slope = np.where(k < period // 4, t, np.where((k >= period // 2) & (k < 3 * period // 4),
                                                  -t, 0.0))
    gx, gy = np.meshgrid(slope, np.roll(slope, 5), indexing="xy")
    return unit(np.stack([gx, gy, np.ones_like(gx)], -1))


def _bilinear_raw(nrm, u, v):
    """nm_bilinear at level 0 (texel centres at half-integers, row 0 = v = 1, repeat) before
    normalising (the kernels' bilinear mean at level 0)."""
    m = nrm.shape[0]
    x = (u % 1.0) * m - 0.5
    y = (1.0 - v % 1.0) * m - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    g = lambda r, c: nrm[r % m, c % m]  # noqa: E731
    return ((g(y0, x0) * (1 - fx) + g(y0, x0 + 1) * fx) * (1 - fy)
            + (g(y0 + 1, x0) * (1 - fx) + g(y0 + 1, x0 + 1) * fx) * fy)


def _bilinear_normals(nrm, u, v):
    """The unit bilinear normal (what the reference shades)."""
    return unit(_bilinear_raw(nrm, u, v))


@pytest.mark.parametrize("texels,box_max", [(8.0, 0.1), (16.0, 0.25)])
def test_box_footprint_is_closer_to_the_box_average_off_the_texel_grid(texels, box_max):
    """A grooves map (128², period 64: as the han07 figures' 256² map at 16×, four pixels per
    period at 16 texels) under pixels of `texels` texels whose grid is offset
    (0.37, 0.61) pixel from the texel grid; truth: the box average over each pixel of the
    shading of the unfiltered bilinear normals (24 × 24 samples), as the reference integrates.
    Relative RMS over the pixels, measured at 8 / 16 texels: vmf (J = 4) trilinear 0.349 /
    0.616, box 0.081 / 0.204 (against the map's texels as deltas, what the pyramid holds, box is
    0.015 / 0.200: the rest at 16 is the texels' sub-texel layout the level cannot know);
    toksvig (one lobe) trilinear 0.347 / 0.578, box 0.347 / 0.428."""
    s, kd = 30.0, 0.15
    nrm = _grooves()
    fit = fit_vmf_pyramid(nrm, VMFSettings(lobes=4))
    pyr = NormalMapPyramid(fit.alpha, fit.alpha_r,
                           [m.astype(np.float32) for m in mean_normal_pyramid(nrm)])
    side, npx = nrm.shape[0], 12
    step = texels / side                                  # one pixel in UV
    c = (np.arange(npx) + 0.5) * step
    pu, pv = np.meshgrid(c + 0.37 * step, c + 0.61 * step, indexing="xy")
    pu, pv = pu.reshape(-1), pv.reshape(-1)
    n = len(pu)
    o = unit([0.15, 0.1, 1.0])
    views = np.tile(o, (n, 1))
    duv = np.tile([step, 0.0, 0.0, step], (n, 1))
    fr = flat_frame(views, np.stack([pu, pv], -1), duv)
    # truth: q × q sub-samples of the pixel box
    q = 24
    off = ((np.arange(q) + 0.5) / q - 0.5) * step
    su = pu[:, None, None] + off[None, None, :]
    sv = pv[:, None, None] + off[None, :, None]
    nn = _bilinear_normals(nrm, np.broadcast_to(su, (n, q, q)), np.broadcast_to(sv, (n, q, q)))
    h = unit(o + LIGHT)
    ci = np.maximum(nn @ LIGHT, 0.0)
    truth = ((kd / math.pi + (s + 2) / (8 * math.pi) * np.maximum(nn @ h, 0.0) ** s) * ci
             ).mean((1, 2))
    err = {}
    for foot in ("trilinear", "box"):
        r = _renderer(pyr, foot, kd=kd, s=s, taps=8)
        for meth in ("vmf", "toksvig"):
            img = r.shade(meth, fr)[:, 0]
            err[foot, meth] = math.sqrt(np.mean((img - truth) ** 2) / np.mean(truth ** 2))
    assert err["box", "vmf"] < box_max, err
    assert err["box", "vmf"] < 0.4 * err["trilinear", "vmf"], err
    assert err["box", "toksvig"] < 1.02 * err["trilinear", "toksvig"], err


def test_box_level0_shades_a_grid_of_bilinear_taps_per_method():
    """Footprint of 1.3 × 0.7 level-0 texels (rotated 30°): a grid of taps at the centres of the
    parallelogram's cells, NM_L0_TAPS_PER_TEXEL (6) per texel along each side up to
    NM_BOX_L0_TAPS (4), each tap its own lobe — every method the material's lobe
    about the unit bilinear normal (toksvig and engine_bake at r = 1: the tap's shorter
    bilinear mean is not roughness) — and its own diffuse max(0, n·i), averaged."""
    from tests.normalmap.helpers import tilted_normals
    s, kd = 40.0, 0.25
    nrm = tilted_normals(8, seed=2, spread=0.5)
    fit = fit_vmf_pyramid(nrm, VMFSettings(lobes=2))
    pyr = NormalMapPyramid(fit.alpha, fit.alpha_r,
                           [m.astype(np.float32) for m in mean_normal_pyramid(nrm)])
    rng = np.random.default_rng(9)
    n = 16
    uv = rng.uniform(0, 1, (n, 2))
    c, sn = math.cos(math.pi / 6), math.sin(math.pi / 6)
    ex, ey = np.array([1.3 * c, 1.3 * sn]) / 8, np.array([-0.7 * sn, 0.7 * c]) / 8
    duv = np.tile(np.concatenate([ex, ey]), (n, 1))
    views = unit(np.tile([0.1, -0.05, 1.0], (n, 1)) + rng.normal(0, 0.2, (n, 3)))
    fr = flat_frame(views, uv, duv)
    nx, ny = min(math.ceil(6 * 1.3), 4), min(math.ceil(6 * 0.7), 4)     # 4 × 4
    ref = {k: np.zeros(n) for k in ("vmf", "normals_mip", "toksvig", "engine_bake")}
    norm0 = (s + 2) / (8 * math.pi)
    for p in range(n):
        for b in range(ny):
            for a in range(nx):
                t = uv[p] + ((a + 0.5) / nx - 0.5) * ex + ((b + 0.5) / ny - 0.5) * ey
                raw = _bilinear_raw(nrm, np.array([t[0]]), np.array([t[1]]))[0]
                r = np.linalg.norm(raw)
                nk = raw / r
                dif = kd / math.pi * max(nk @ LIGHT, 0.0)
                spec = blinn_lobe(nk, views[p], LIGHT, s, norm0)
                for k in ref:
                    ref[k][p] += (dif + spec) / (nx * ny)
    r = _renderer(pyr, "box", kd=kd, s=s)
    for meth, want in ref.items():
        np.testing.assert_allclose(r.shade(meth, fr)[:, 0], want, rtol=5e-4, atol=1e-5,
                                   err_msg=meth)


def test_elongated_footprint_keeps_the_trilinear_taps():
    """With 8 taps, a footprint 6 × 0.9 texels (its box would need level 2 of this map, the
    taps level 0) shades exactly as trilinear; a 3.3 × 3.3 one does not."""
    rng = np.random.default_rng(4)
    pyr, mus, _ = _lobe_pyramid(rng, 300.0)
    n = 12
    uv = rng.uniform(0, 1, (n, 2))
    views = unit(np.tile([0.1, -0.05, 1.0], (n, 1)) + rng.normal(0, 0.2, (n, 3)))
    out = {}
    for name, (a, b) in {"long": (6.0, 0.9), "square": (3.3, 3.3)}.items():
        duv = np.tile([a / 8, 0.0, 0.0, b / 8], (n, 1))
        fr = flat_frame(views, uv, duv)
        out[name] = [_renderer(pyr, f, kd=0.2, taps=8).shade("vmf", fr)[:, 0]
                     for f in ("trilinear", "box")]
    np.testing.assert_array_equal(out["long"][0], out["long"][1])
    assert np.abs(out["square"][0] - out["square"][1]).max() > 0.02
