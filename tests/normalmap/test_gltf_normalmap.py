"""The normal-map methods on glTF assets: a textured gltf_pbr material's per-pixel base colour,
metallic and roughness (filtered over the footprint, as sg reads them)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.scene import gltf_builder as gb

NM = ("normals_mip", "vmf", "toksvig", "engine_bake")


@pytest.mark.parametrize("light", [True, False], ids=["point_light", "environment"])
def test_textured_halves_render_as_their_uniform_materials(tmp_path, light):
    """The halves quad (left: dielectric roughness 0.3, right: metal roughness 0.7; no normal
    texture): away from the seam each normal-map method renders each half within 2 % of its
    own render of that half's uniform material (the factors — roughness 1, metal — are ≥ 20 %
    off)."""
    tex, uniform = gb.halves_quads(tmp_path)
    img = gb.render_quad(tmp_path, tex, "tex", NM, light=light)
    half = {tag: gb.render_quad(tmp_path, glb, tag, NM, light=light)
            for tag, glb in uniform.items()}
    factors = gb.render_quad(tmp_path, gb.write_glb(gb.textured_quad(), tmp_path / "f.glb"),
                             "factors", NM[:1], light=light)
    cols = np.arange(32)
    rows = slice(6, 26)
    for sel, tag in ((cols < 13, "a"), (cols > 18, "b")):
        for m in NM:
            want = half[tag][m][rows][:, sel]
            assert np.abs(want).max() > 0.02
            err = np.abs(img[m][rows][:, sel] - want).mean() / np.abs(want).mean()
            assert err <= 0.02, (m, tag, err)
        want = half[tag]["normals_mip"][rows][:, sel]
        off = np.abs(factors["normals_mip"][rows][:, sel] - want).mean() / np.abs(want).mean()
        assert off >= 0.2, (tag, off)
