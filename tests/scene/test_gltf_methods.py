"""Textured glTF materials in the OpenCL methods `sg` and `fis`: each pixel's base colour,
metallic and roughness from its textures (shading.h gltf_pixel_record), the roughness grid's
interpolated lobes (fit.ndf_sg_rough), the footprint-filtered lookups (tex_filtered)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from sgpipe.brdf.ndf import GGXNDF
from sgpipe.fit.ndf_sg import fit_ndf_sg
from sgpipe.fit.ndf_sg_rough import fit_roughness_grid
from sgpipe.render.textures import Textures, mip_chain

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1] / "render"))
import gltf_builder as gb  # noqa: E402


# -- the roughness grid -------------------------------------------------------------------
def test_roughness_grid_lobes_follow_the_ndf():
    """Every entry up to α 0.25 fits GGX as well as a direct 4-lobe fit, and the lobes
    interpolated at any α of the range (40 log-uniform draws, quadrature of ndf_sg) stay within
    1.2 % relative L2 of the exact D up to α 0.5 (5 % above, where the lobes' sharpness floor
    keeps them from flattening with GGX): one lobe set per pixel's roughness suffices."""
    from sgpipe.fit.ndf_sg import iso_quadrature, rel_l2
    grid = fit_roughness_grid(GGXNDF)
    assert grid.sharpness.shape == (49, 4)
    for i in (0, 12, 24, 36):
        direct = fit_ndf_sg(GGXNDF(grid.alpha[i]), method="lm", n_lobes=4)
        assert grid.rel_l2[i] <= max(1.05 * direct.rel_l2, 0.004)
    rng = np.random.default_rng(11)
    for a in np.exp(rng.uniform(np.log(grid.alpha[0]), 0.0, 40)):
        c, w = iso_quadrature(a)
        h = np.stack([np.sqrt(1 - c * c), 0 * c, c], -1)
        lam, mu = grid.lobes_at(a)
        err = rel_l2(GGXNDF(a).eval(h), np.exp(lam * (c[:, None] - 1.0)) @ mu, w)
        assert err <= (0.012 if a <= 0.5 else 0.05), (a, err)
    # the interpolation is what the kernels compute: at a grid α it is that entry
    lam, mu = grid.lobes_at(grid.alpha[7])
    np.testing.assert_allclose(lam, grid.sharpness[7], rtol=1e-9)
    np.testing.assert_allclose(mu, grid.amplitude[7], rtol=1e-9)


# -- texture lookups ----------------------------------------------------------------------
def test_mip_levels_are_exact_box_averages():
    rng = np.random.default_rng(3)
    img = rng.random((7, 10, 3))
    levels = mip_chain(img)
    assert [lv.shape[:2] for lv in levels] == [(7, 10), (3, 5), (1, 2), (1, 1)]
    for lv in levels:
        np.testing.assert_allclose(lv.mean((0, 1)), img.mean((0, 1)), rtol=1e-12)
    # level 1 texel (0, 0) covers rows [0, 7/3) and columns [0, 2)
    w = np.array([1.0, 1.0, 1.0 / 3.0])
    np.testing.assert_allclose(levels[1][0, 0], (w[:, None, None] * img[:3, :2]).sum((0, 1))
                               / (w.sum() * 2))


def _box_taps_np(tex, levels, uv, duv, taps=4):
    """numpy port of shading.h tex_filtered: n_x × n_y bilinear taps over the footprint
    parallelogram at the finest level where a side needs ≤ `taps` taps of one texel."""
    from sgpipe.io.gltf_textures import GltfTexture
    out = np.zeros((len(uv), 3))
    h, w = tex.image.shape[:2]
    for i, (p, d) in enumerate(zip(uv, duv)):
        dx, dy = np.array([d[0], -d[1]]), np.array([d[2], -d[3]])
        if tex.matrix is not None:
            dx, dy = tex.matrix[:2, :2] @ dx, tex.matrix[:2, :2] @ dy
        lx, ly = np.hypot(dx[0] * w, dx[1] * h), np.hypot(dy[0] * w, dy[1] * h)
        need = max(lx, ly) / taps
        lv = min(int(np.ceil(np.log2(need))), len(levels) - 1) if need > 1 else 0
        nx = int(np.clip(np.ceil(lx / 2 ** lv - 1e-3), 1, taps))
        ny = int(np.clip(np.ceil(ly / 2 ** lv - 1e-3), 1, taps))
        level = GltfTexture(levels[lv], tex.wrap, tex.matrix)
        acc = 0.0
        for j in range(ny):
            for k in range(nx):
                a, b = (k + 0.5) / nx - 0.5, (j + 0.5) / ny - 0.5
                # a step in (s, t) of a·dx + b·dy is, in sgpipe's uv, (a·du, a·dv) with the
                # transform undone: step the uv by the pixel derivatives themselves
                q = p + a * np.array(d[:2]) + b * np.array(d[2:])
                acc = acc + level.bilinear(q[None])[0]
        out[i] = acc / (nx * ny)
    return out


def test_kernel_lookup_is_the_box_footprint_over_mip_levels():
    """tex_filtered at a zero footprint is GltfTexture.bilinear (wrap modes, transform, top-left
    origin); at any footprint it is the n_x × n_y taps of its rule (a numpy port, footprints of
    0.5–60 texels, the transform's scaling included); and on a smooth image it is the box
    average over the footprint (brute force, 64 × 64 samples) within 0.01 up to footprints of
    32 texels (0.04 beyond, where a footprint covers half this 128 × 64 image)."""
    from sg_testlib import run_kernel
    from sgpipe.io.gltf_textures import CLAMP, MIRROR, REPEAT, GltfTexture
    rng = np.random.default_rng(5)
    img = rng.random((64, 128, 3))
    yy, xx = np.mgrid[0:64, 0:128]
    smooth = np.stack([0.5 + 0.4 * np.sin(2 * np.pi * xx / 128) * np.cos(2 * np.pi * yy / 64),
                       0.5 + 0.3 * np.cos(2 * np.pi * 2 * xx / 128),
                       0.2 + 0.1 * np.sin(2 * np.pi * yy / 64)], -1)
    t = Textures()
    cases = [GltfTexture(img, (REPEAT, CLAMP)), GltfTexture(img, (MIRROR, REPEAT)),
             GltfTexture(img, (REPEAT, REPEAT), np.array([[0.0, -2.0, 0.3], [1.5, 0.0, 0.1],
                                                          [0.0, 0.0, 1.0]])),
             GltfTexture(smooth, (REPEAT, REPEAT))]
    for c in cases:
        t.add(c.image, mip=True, wrap=c.wrap, matrix=c.matrix)
    texels, info, aff = t.pack()
    n = 300
    uv = rng.uniform(-1.5, 2.5, (n, 2)).astype(np.float32)

    def kernel(k, duv):
        out, = run_kernel("t_tex", n, [texels, info, aff.reshape(-1, 4), np.int32(k), uv,
                                       duv.astype(np.float32)], [((n, 4), np.float32)])
        return out[:, :3]
    zero = np.zeros((n, 4), np.float32)
    for k, c in enumerate(cases):
        np.testing.assert_allclose(kernel(k, zero), c.bilinear(uv), atol=1e-4)
    # footprints from half a texel to 60 texels, oblique
    scale = np.exp(rng.uniform(np.log(0.5), np.log(60.0), n))[:, None]
    ang = rng.uniform(0, np.pi, (n, 2))
    duv = np.concatenate([np.cos(ang[:, :1]) / 128, np.sin(ang[:, :1]) / 64,
                          0.6 * np.cos(ang[:, 1:]) / 128, 0.6 * np.sin(ang[:, 1:]) / 64],
                         1) * scale
    for k in (0, 2):
        np.testing.assert_allclose(kernel(k, duv), _box_taps_np(
            cases[k], mip_chain(cases[k].image), uv, duv), atol=1e-4)
    got = kernel(3, duv)
    a, b = np.meshgrid((np.arange(64) + 0.5) / 64 - 0.5, (np.arange(64) + 0.5) / 64 - 0.5)
    for i in range(0, n, 15):
        q = uv[i] + a.reshape(-1, 1) * duv[i, :2] + b.reshape(-1, 1) * duv[i, 2:]
        want = cases[3].bilinear(q).mean(0)
        # each tap is a bilinear texel of its level: a little wider than the box, which shows
        # where the footprint spans a good part of this 128 × 64 image
        np.testing.assert_allclose(got[i], want, atol=0.01 if scale[i, 0] <= 32 else 0.04)


# -- per-pixel materials in sg and fis ----------------------------------------------------
def _render(tmp_path, glb: Path, tag: str, light: bool) -> dict:
    return gb.render_quad(tmp_path, glb, tag, ("sg", "fis"), light=light,
                          render="  fis_samples: 256\n")


@pytest.mark.parametrize("light", [True, False], ids=["point_light", "environment"])
def test_textured_halves_render_as_their_uniform_materials(tmp_path, light):
    """Left half: base A, roughness 0.3, dielectric; right half: base B, roughness 0.7, metal.
    Away from the seam each method renders every pixel as the uniform material of its half:
    under a point light exactly (the exact BRDF at the light: analytic D vs the uniform
    material's table), under the environment within the roughness grid's lobes against the
    uniform material's own fit."""
    tex, uniform = gb.halves_quads(tmp_path)
    img = _render(tmp_path, tex, "tex", light)
    half = {tag: _render(tmp_path, glb, tag, light) for tag, glb in uniform.items()}
    cols = np.arange(32)
    left, right = cols < 13, cols > 18               # the seam is at column 16
    rows = slice(6, 26)
    tol = {"sg": 2e-3 if light else 0.01, "fis": 2e-3 if light else 0.01}
    for method in ("sg", "fis"):
        got = img[method][rows]
        assert np.abs(got).max() > 0.02
        for sel, tag in ((left, "a"), (right, "b")):
            want = half[tag][method][rows][:, sel]
            err = np.abs(got[:, sel] - want).mean() / np.abs(want).mean()
            assert err <= tol[method], (method, tag, err)
        # the halves differ: the test could not pass by ignoring the textures
        assert np.abs(half["a"][method][rows][:, left]
                      - half["b"][method][rows][:, left]).mean() > 0.2 * np.abs(
                          half["a"][method][rows][:, left]).mean()


def test_linear_parameters_per_texel():
    """kd = (1 − m)c, F0 = lerp(0.04, c, m), ln r with the factors applied, on the textures'
    shared grid; none when the two textures' grids differ."""
    from sgpipe.io.gltf_textures import CLAMP, REPEAT, GltfTexture
    from sgpipe.render.materials import GltfFactors
    from sgpipe.render.setup import linear_parameters
    rng = np.random.default_rng(2)
    c, mr = rng.random((8, 16, 3)), rng.random((8, 16, 3))
    g = GltfFactors(np.array([0.5, 1.0, 0.8]), 0.9, 0.7)
    (a, b), tex = linear_parameters(g, GltfTexture(c), GltfTexture(mr))
    base, metal, rough = c * g.base_color, 0.9 * mr[..., 2:3], 0.7 * mr[..., 1]
    np.testing.assert_allclose(a[..., :3], (1 - metal) * base)
    np.testing.assert_allclose(b[..., :3], 0.04 * (1 - metal) + metal * base)
    np.testing.assert_allclose(a[..., 3], np.log(np.maximum(rough, 0.06)))
    np.testing.assert_allclose(b[..., 3], metal[..., 0])
    assert tex.image is c
    # only one texture: the other parameters are the factors
    (a, b), _ = linear_parameters(g, None, GltfTexture(mr))
    np.testing.assert_allclose(a[..., :3], (1 - metal) * g.base_color)
    assert linear_parameters(g, GltfTexture(c), GltfTexture(mr, (REPEAT, CLAMP))) is None
    assert linear_parameters(g, GltfTexture(c), GltfTexture(mr[:4])) is None


def test_finest_level_reads_each_point_as_the_reference():
    """A textured material's parameters (gltf_filtered_params) over a footprint at the finest
    level are the reference's at each tap (GltfSurface.params: base colour, metallic and
    roughness mixed bilinearly, then kd = (1 − m)c, F0 = lerp(0.04, c, m)), the taps' kd and F0
    averaged and their roughness' geometric mean; coarser footprints read the linear
    parameters' MIPs. Between a metal and a dielectric texel the bilinear mix of kd and F0
    themselves differs from the point's by > 0.05: the test tells the two readings apart."""
    from sg_testlib import run_kernel
    from sgpipe.io.gltf_textures import REPEAT, GltfTexture
    from sgpipe.reference.surface import GltfSurface
    from sgpipe.render.materials import GltfFactors
    from sgpipe.render.records import MAT_STRIDE, MaterialSlot as S
    from sgpipe.render.setup import linear_parameters
    rng = np.random.default_rng(8)
    c = rng.uniform(0.05, 1.0, (16, 32, 3))
    mr = np.stack([np.zeros((16, 32)), rng.uniform(0.1, 1.0, (16, 32)),
                   (rng.random((16, 32)) < 0.5).astype(float)], -1)     # metal or not
    g = GltfFactors(np.array([0.9, 1.0, 0.8]), 1.0, 0.9)
    (a, b), _ = linear_parameters(g, GltfTexture(c), GltfTexture(mr))
    t = Textures()
    for img in (a, b):
        t.add(img, mip=True, wrap=(REPEAT, REPEAT), matrix=None)
    texels, info, aff = t.pack()
    mat = np.zeros(MAT_STRIDE, np.float32)
    mat[S.BASE:S.BASE + 3], mat[S.METAL], mat[S.ROUGH] = g.base_color, 1.0, 0.9
    mat[S.BCTEX], mat[S.MRTEX], mat[S.SVLIN] = 0, 1, 1
    n = 400
    uv = rng.uniform(-0.5, 1.5, (n, 2))

    def kernel(duv):
        kd, f0 = run_kernel("t_gltf_params", n, [mat, texels, info, aff.reshape(-1, 4),
                                                 uv.astype(np.float32),
                                                 np.asarray(duv, np.float32)],
                            [((n, 4), np.float32), ((n, 4), np.float32)])
        return kd[:, :3], f0[:, :3], kd[:, 3]

    def point(q):
        """The reference's kd, F0 and roughness at uv q."""
        p = GltfSurface(g.base_color, 1.0, 0.9, GltfTexture(c), GltfTexture(mr)).params(q)
        m = p[:, 3:4]
        return (1 - m) * p[:, :3], 0.04 * (1 - m) + m * p[:, :3], p[:, 4]
    kd, f0, r = kernel(np.zeros((n, 4)))
    want = point(uv)
    for got, w in zip((kd, f0, r), want):
        np.testing.assert_allclose(got, w, atol=2e-5)
    mixed = GltfTexture(a).bilinear(uv)[:, :3]
    assert np.abs(mixed - want[0]).max() > 0.05
    # a footprint of about 2 × 1.5 texels: 2 × 2 taps at level 0, each the point's parameters
    duv = np.tile([2.0 / 32, 0.0, 0.0, 1.5 / 16], (n, 1))
    kd, f0, r = kernel(duv)
    taps = [point(uv + i * duv[:, :2] + j * duv[:, 2:]) for i in (-0.25, 0.25)
            for j in (-0.25, 0.25)]
    np.testing.assert_allclose(kd, np.mean([tp[0] for tp in taps], 0), atol=2e-5)
    np.testing.assert_allclose(f0, np.mean([tp[1] for tp in taps], 0), atol=2e-5)
    np.testing.assert_allclose(r, np.exp(np.mean([np.log(tp[2]) for tp in taps], 0)),
                               rtol=2e-5)
    # 12 texels wide: level 1 of the linear parameters' MIPs, as tex_filtered reads them
    duv = np.tile([12.0 / 32, 0.0, 0.0, 1.0 / 16], (n, 1))
    kd, f0, r = kernel(duv)
    for got, img in ((kd, a[..., :3]), (f0, b[..., :3]), (np.log(r), a[..., [3, 3, 3]])):
        want = _box_taps_np(GltfTexture(img), mip_chain(img), uv, duv)
        np.testing.assert_allclose(got, want if got.ndim == 2 else want[:, 0], atol=2e-5)
