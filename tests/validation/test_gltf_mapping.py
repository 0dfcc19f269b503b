"""The glTF metal-rough material mapped onto Mitsuba (validation.gltf): the squared roughness
bitmap against sgpipe's own per-pixel parameters, what is refused, the generated asset (with
Mitsuba installed, tests/validation/test_mitsuba_agrees.py evaluates the mapped BSDF)."""

import numpy as np
import pytest

from sgpipe.config.sections.fit import MaterialSpec
from sgpipe.io.gltf_textures import CLAMP, GltfTexture
from sgpipe.reference.surface import GltfSurface
from validation import assets
from validation import gltf as vg
from validation import textures as tx
from validation.conventions import Unmappable

WHITE_METAL = {"base_color": [1.0, 1.0, 1.0], "metallic": 1.0, "roughness": 1.0,
               "anisotropy": 0.0}


def _spec(**over):
    return MaterialSpec(name="m", model="gltf_pbr", params={**WHITE_METAL, **over})


def _mr_texture():
    return GltfTexture(vg.rough_metal_texture().astype(float) / 255.0)


def test_alpha_bitmap_is_the_references_alpha_at_any_uv():
    """Mitsuba's bilinear lookup of the squared texels = sgpipe's (bilinear roughness)² within
    the smooth texture's (Δr_u + Δr_v)²/4 bound; the unreversed rows (a flipped lookup) are
    far off."""
    mr = _mr_texture()
    d = vg.gltf_bsdf_dict(_spec(), (None, None, mr))
    alpha = d["bsdf"]["alpha"]["data"]
    uv = np.random.default_rng(3).uniform(-1.5, 2.5, (4000, 2))
    rough = GltfSurface(np.ones(3), 1.0, 1.0, None, mr).params(uv)[:, 4]
    want = np.maximum(rough, 0.06) ** 2
    got = tx.mitsuba_bitmap_eval(alpha, uv)[:, 0]
    # bilinear(r²) − bilinear(r)² ≤ (Δr_u + Δr_v)²/4, Δr the largest step between neighbours
    step = sum(np.abs(np.diff(mr.image[..., 1], axis=a)).max() for a in (0, 1))
    assert np.abs(got - want).max() <= step ** 2 / 4 + 1e-6
    flipped = tx.mitsuba_bitmap_eval(np.ascontiguousarray(alpha[::-1]), uv)[:, 0]
    assert np.abs(flipped - want).max() > 0.05


def test_the_field_has_no_mirror_symmetry_and_spans_its_range():
    u, v = np.meshgrid(np.linspace(0, 1, 65), np.linspace(0, 1, 33))
    r = vg.roughness_field(u, v)
    assert 0.17 < r.min() < 0.2 and 0.64 < r.max() < 0.68
    assert np.abs(r - vg.roughness_field(1 - u, v)).max() > 0.1
    assert np.abs(r - vg.roughness_field(u, 1 - v)).max() > 0.1


def test_untextured_roughness_is_a_constant_alpha():
    d = vg.gltf_bsdf_dict(_spec(roughness=0.5), None)
    assert d["bsdf"]["alpha"] == pytest.approx(0.25)
    assert vg.gltf_bsdf_dict(_spec(roughness=0.0), None)["bsdf"]["alpha"] == pytest.approx(
        0.06 ** 2)


@pytest.mark.parametrize("over,textures,what", [
    ({"metallic": 0.5}, None, "metallic"),
    ({"base_color": [1.0, 0.8, 0.5]}, None, "base colour"),
    ({"anisotropy": 0.3}, None, "anisotropy"),
    ({"emissive": [1.0, 0.0, 0.0]}, None, "emission"),
    ({}, (None, GltfTexture(np.full((2, 2, 3), 0.9)), None), "base colour"),
    ({}, (None, None, GltfTexture(np.full((2, 2, 3), 0.5))), "metallic"),
    ({}, (None, None, GltfTexture(np.ones((2, 2, 3)), (CLAMP, CLAMP))), "wrap")])
def test_what_mitsuba_cannot_express_is_refused(over, textures, what):
    with pytest.raises(Unmappable, match=what):
        vg.gltf_bsdf_dict(_spec(**over), textures)


def test_generated_asset_is_deterministic_and_read_back(tmp_path):
    from sgpipe.io.gltf import read_gltf
    from sgpipe.io.gltf_textures import material_texture
    a = assets.ensure("rough_metal_ball.glb", tmp_path)
    b = assets.ensure("rough_metal_ball.glb", tmp_path / "again")
    assert a.read_bytes() == b.read_bytes()
    asset = read_gltf(a)
    tex = material_texture(asset, 0, "metallicRoughnessTexture")
    np.testing.assert_array_equal(np.round(tex.image * 255), vg.rough_metal_texture())

