"""glTF normal textures as the normal-map methods' input: each glTF material's `normalTexture`
(its `scale` applied, as every method reads it: render.setup.gltf_normal_texture) becomes one
map of the normalmap stage, shared by the primitives that use the material."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput

#: the pyramid's addressing per axis (nm_info's wrap bits: REPEAT 0, CLAMP_TO_EDGE 1)
WRAP_NAMES = {10497: "repeat", 33071: "clamp"}


def gltf_normal_maps(cfg, taken: set[str], with_features: bool = False) -> list[dict]:
    """{name, path, key, objects, textures, texels, wrap} per glTF material with a normal
    texture used by a scene object without a `normal_map` of its own; names
    `<file stem>_<material>` (unique against `taken`, which grows). BadInput for a texture
    the pyramids cannot hold: not square power-of-two, MIRRORED_REPEAT, KHR_texture_transform.
    `with_features`: also `material` = (factors, base-colour, metallic-roughness GltfTexture)
    where the material has either texture (render.setup.gltf_textures)."""
    from sgpipe.normalmap.read import validate_texels
    from sgpipe.render.setup import _gltf_material, gltf_normal_texture, gltf_textures
    assets: dict = {}
    maps: dict[tuple, dict] = {}
    for o in cfg.scene.objects if cfg.scene is not None else []:
        if o.normal_map is not None:
            continue
        found = _gltf_material(cfg, o, assets)
        if found is None:
            continue
        _, asset, index = found
        key = (str(Path(asset.path).resolve()), index)
        if key not in maps:
            tex = gltf_normal_texture(cfg, o, assets)
            if tex is None:
                continue
            where = f"materials[{index}].normalTexture"
            if tex.matrix is not None:
                raise BadInput("the normal-map methods read normal textures without "
                               "KHR_texture_transform", file=asset.path, key=where)
            if any(w not in WRAP_NAMES for w in tex.wrap):
                raise BadInput("the normal-map methods read normal textures with REPEAT or "
                               "CLAMP_TO_EDGE samplers, not MIRRORED_REPEAT", file=asset.path,
                               key=where)
            img = np.asarray(tex.image, np.float64)
            validate_texels(img if img.shape[2] in (3, 4) else img[..., :3], asset.path, where,
                            is_exr=False)
            mat = asset.doc.materials[index].name or f"material{index}"
            stem = re.sub(r"[^A-Za-z0-9_.-]", "_", f"{Path(asset.path).stem}_{mat}")
            name, i = stem, 1
            while name in taken:
                i += 1
                name = f"{stem}-{i}"
            taken.add(name)
            maps[key] = {"name": name, "path": o.mesh, "key": where, "objects": [],
                         "textures": (None, None), "texels": np.ascontiguousarray(img[..., :3]),
                         "wrap": [WRAP_NAMES[w] for w in tex.wrap]}
            textured = gltf_textures(cfg, o, assets) if with_features else None
            if textured is not None and (textured[1] is not None or textured[2] is not None):
                spec, base, mr, _ = textured
                maps[key]["material"] = (dict(spec.params or {}), base, mr)
        maps[key]["objects"].append(o.name)
    return list(maps.values())
