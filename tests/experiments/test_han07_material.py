"""The Han07 glTF material subject's asset (sgpipe.experiments.han07_material)."""

from __future__ import annotations

import numpy as np


def test_plane_asset_carries_the_facet_materials(tmp_path):
    """The plane .glb: one material with the grooves map as its normal texture and a base
    colour and roughness / metalness per facet cluster (each CLUSTERS entry on ≥ 5 % of the
    texels, its 8-bit value read back from the asset), UVs repeating the textures `rep`
    times."""
    from sgpipe.experiments import han07 as H
    from sgpipe.experiments import han07_material as M
    from sgpipe.io.gltf import primitive_geometry, read_gltf
    from sgpipe.io.gltf_textures import material_texture
    from sgpipe.io.png import srgb_to_linear
    images = M.material_images(H.DATA / H.MAPS["grooves"])
    asset = read_gltf(M.plane_glb(tmp_path / "plane.glb", 2.5, images))
    prim = asset.primitives[0]
    base = material_texture(asset, prim.material, "baseColorTexture").image[..., :3]
    mr = material_texture(asset, prim.material, "metallicRoughnessTexture").image
    normal = material_texture(asset, prim.material, "normalTexture").image[..., :3]
    assert np.allclose(normal, np.round(images[0] * 255) / 255, atol=1e-6)
    for _, c, r, m in M.CLUSTERS:
        want = srgb_to_linear(np.round(np.asarray(c) * 255) / 255)
        sel = np.all(np.abs(base - want) < 1e-6, axis=-1)
        assert sel.mean() >= 0.05, c
        assert np.allclose(mr[sel, 1], np.round(r * 255) / 255, atol=1e-6)
        assert np.allclose(mr[sel, 2], m, atol=1e-6)
    geo = primitive_geometry(asset, prim)
    uv, pos = np.asarray(geo["uvs"]), np.asarray(geo["positions"])
    assert np.isclose(np.ptp(uv[:, 0]), 2.5) and np.isclose(np.ptp(uv[:, 1]), 2.5)
    # u along +x, v along −z (floor.obj's): the textures' orientation on Fig 2's plane
    assert np.corrcoef(uv[:, 0], pos[:, 0])[0, 1] > 0.99
    assert np.corrcoef(uv[:, 1], -pos[:, 2])[0, 1] > 0.99
