"""Textured glTF materials in the OpenCL methods `sg` and `fis`: each pixel's base colour,
metallic and roughness from its textures (shading.h gltf_pixel_record), the roughness grid's
interpolated lobes (fit.ndf_sg_rough), the footprint-filtered lookups (tex_filtered)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sgpipe.brdf.ndf import GGXNDF
from sgpipe.fit.ndf_sg import fit_ndf_sg
from sgpipe.fit.ndf_sg_rough import fit_roughness_grid
from sgpipe.io.png import srgb_to_linear
from sgpipe.render.textures import Textures, mip_chain

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1] / "render"))
import gltf_builder as gb  # noqa: E402

A = np.array([0.8, 0.3, 0.1])
B = np.array([0.1, 0.4, 0.9])
STUDIO = Path(__file__).resolve().parents[2] / "data_samples" / "studio.exr"


def _halves(a, b, size=32) -> np.ndarray:
    img = np.empty((size, size, 3))
    img[:, : size // 2] = a
    img[:, size // 2:] = b
    return img


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


def test_kernel_lookup_matches_the_gltf_sampler_and_its_mip_levels():
    """tex_filtered at a zero footprint is GltfTexture.bilinear (wrap modes, transform, top-left
    origin); a footprint of exactly 2 texels reads level 1 bilinearly."""
    from sg_testlib import run_kernel
    from sgpipe.io.gltf_textures import CLAMP, MIRROR, REPEAT, GltfTexture
    rng = np.random.default_rng(5)
    img = rng.random((16, 32, 3))
    t = Textures()
    cases = [GltfTexture(img, (REPEAT, CLAMP)), GltfTexture(img, (MIRROR, REPEAT)),
             GltfTexture(img, (REPEAT, REPEAT), np.array([[0.0, -2.0, 0.3], [1.5, 0.0, 0.1],
                                                          [0.0, 0.0, 1.0]]))]
    for c in cases:
        t.add(c.image, mip=True, wrap=c.wrap, matrix=c.matrix)
    texels, info, aff = t.pack()
    uv = rng.uniform(-1.5, 2.5, (500, 2)).astype(np.float32)
    zero = np.zeros((500, 4), np.float32)
    for k, c in enumerate(cases):
        out, = run_kernel("t_tex", 500, [texels, info, aff.reshape(-1, 4), np.int32(k), uv, zero],
                          [((500, 4), np.float32)])
        np.testing.assert_allclose(out[:, :3], c.bilinear(uv), atol=2e-5)
    # footprint 2 texels along u (∂u/∂x = 2/32): level 1 (16 × 8), bilinear
    duv = np.tile(np.float32([2.0 / 32, 0.0, 0.0, 1.0 / 16]), (500, 1))
    out, = run_kernel("t_tex", 500, [texels, info, aff.reshape(-1, 4), np.int32(0), uv, duv],
                      [((500, 4), np.float32)])
    lv1 = GltfTexture(mip_chain(img)[1], (REPEAT, CLAMP))
    np.testing.assert_allclose(out[:, :3], lv1.bilinear(uv), atol=2e-5)


# -- per-pixel materials in sg and fis ----------------------------------------------------
def _render(tmp_path, glb: Path, tag: str, light: bool) -> dict:
    from sgpipe.io import read_exr
    cfg = tmp_path / f"{tag}.yaml"
    lights = ("lights: [{type: point, position: [0.6, 0.4, 1.5], intensity: [5, 5, 5], "
              "radius: 0.0}]\n  environment_exposure: -30" if light else
              "environment_exposure: -2")
    cfg.write_text(f"""
scene: {{gltf: [{{file: {glb}}}]}}
fit: {{view_gmm: {{enabled: false}}}}
envmap: {{environment: {STUDIO}, cube_resolution: 32}}
render:
  camera: {{eye: [0, 0, 3.0], target: [0, 0, 0], fov_deg: 30, width: 32, height: 32}}
  methods: [sg, fis]
  fis_samples: 256
  {lights}
""")
    out = tmp_path / f"out_{tag}"
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(cfg), "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    return {m: read_exr(out / "render" / f"{m}.exr")[..., :3] for m in ("sg", "fis")}


@pytest.mark.parametrize("light", [True, False], ids=["point_light", "environment"])
def test_textured_halves_render_as_their_uniform_materials(tmp_path, light):
    """Left half: base A, roughness 0.3, dielectric; right half: base B, roughness 0.7, metal.
    Away from the seam each method renders every pixel as the uniform material of its half:
    under a point light exactly (the exact BRDF at the light: analytic D vs the uniform
    material's table), under the environment within the roughness grid's lobes against the
    uniform material's own fit."""
    mr = _halves([0, 0.3, 0.0], [0, 0.7, 1.0])
    tex = gb.write_glb(gb.textured_quad(_halves(A, B), mr), tmp_path / "tex.glb")
    img = _render(tmp_path, tex, "tex", light)
    lin = lambda c: srgb_to_linear(np.round(c * 255) / 255)   # noqa: E731 - the PNG's 8 bits
    half = {}
    for tag, c, r, m in (("a", A, np.round(0.3 * 255) / 255, 0.0),
                         ("b", B, np.round(0.7 * 255) / 255, 1.0)):
        glb = gb.write_glb(gb.textured_quad(base=tuple(lin(c)), metallic=m, roughness=r),
                           tmp_path / f"{tag}.glb")
        half[tag] = _render(tmp_path, glb, tag, light)
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
