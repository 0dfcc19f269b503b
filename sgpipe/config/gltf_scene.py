"""`scene.gltf` entries expanded into plain scene objects and `gltf_pbr` materials when a config
is loaded, so that every stage sees one kind of object (a mesh file, here a glTF primitive) and
one kind of material (a model with parameters)."""

from __future__ import annotations

import sys
from pathlib import Path

from sgpipe.errors import BadInput


def _descendants(doc, roots: list[int]) -> set[int]:
    out, stack = set(), list(roots)
    while stack:
        i = stack.pop()
        if i in out:
            continue
        out.add(i)
        stack.extend(doc.nodes[i].children or [])
    return out


def _unique(name: str, taken: set[str], tag: str) -> str:
    """`name`, or `name-tag` when it is taken (two glTF nodes or materials may share a name)."""
    out = name if name not in taken else f"{name}-{tag}"
    taken.add(out)
    return out


#: which methods read which glTF textures: the per-pixel parameters the reference, sg, fis, gmm
#: (isotropic materials), transport (its BRDF lobes and diffuse colour; its Gaussians fitted
#: per vertex with the textures filtered there) and the normal-map methods (filtered over the
#: footprint); the others render the material's factors; the normal and emissive textures every method that
#: renders `gltf_pbr`
PER_PIXEL_TEXTURES = ("baseColorTexture", "metallicRoughnessTexture")
EVERY_METHOD_TEXTURES = ("normalTexture", "emissiveTexture")
#: KHR_materials_anisotropy's texture: its direction every method that turns the BRDF frame,
#: its strength the per-pixel exact BRDFs (reference, fis); sg's lobes keep the factor's
ANISOTROPY_TEXTURE = "KHR_materials_anisotropy.anisotropyTexture"


def _texture_note(textures: list[str]) -> str:
    """One line saying which methods read which of a material's textures."""
    parts = []
    per_pixel = [t for t in textures if t in PER_PIXEL_TEXTURES]
    every = [t for t in textures if t in EVERY_METHOD_TEXTURES]
    unread = [t for t in textures
              if t not in PER_PIXEL_TEXTURES + EVERY_METHOD_TEXTURES + (ANISOTROPY_TEXTURE,)]
    if per_pixel:
        parts.append(f"reference, sg, fis, gmm, transport and the normal-map methods read its "
                     f"{' and '.join(per_pixel)} (transport_green06 filtered to the "
                     f"transport mesh's vertices), the other methods its factors")
    if every:
        parts.append(f"every method reads its {' and '.join(every)}")
    if ANISOTROPY_TEXTURE in textures:
        parts.append(f"every method reads its {ANISOTROPY_TEXTURE}'s direction, the reference "
                     "and fis also its strength (sg's lobes keep the factor's)")
    if unread:
        parts.append(f"{', '.join(unread)} not read")
    return "; ".join(parts)


def expand_gltf(cfg) -> None:
    """Append one ObjectSpec per triangle primitive of each `scene.gltf` file (or of its
    selected nodes) and one `gltf_pbr` MaterialSpec per glTF material those use (its factors;
    the glTF default material where a primitive names none). Textures the renderers do not
    read are reported, one line per material."""
    scene = cfg.scene
    if scene is None or not scene.gltf:
        return
    from sgpipe.config.sections.fit import FitSection, MaterialSpec
    from sgpipe.config.sections.scene import ObjectSpec
    from sgpipe.io.gltf import read_gltf, safe_name
    if cfg.fit is None:
        cfg.fit = FitSection()
    objects = {o.name for o in scene.objects}
    materials = {m.name for m in cfg.fit.materials}
    for k, g in enumerate(scene.gltf):
        key = f"scene.gltf.{k}"
        asset = read_gltf(Path(g.file))
        names = {n.name: i for i, n in enumerate(asset.doc.nodes or []) if n.name}
        refs = asset.primitives
        if g.nodes:
            missing = [n for n in g.nodes if n not in names]
            if missing:
                raise BadInput(f"no node named {missing[0]!r} (nodes: "
                               f"{', '.join(sorted(names)[:12]) or 'none named'})",
                               file=g.file, key=f"{key}.nodes")
            keep = _descendants(asset.doc, [names[n] for n in g.nodes])
            refs = [r for r in refs if r.node in keep]
        if not refs:
            raise BadInput("no triangle primitive in the selected nodes", file=g.file,
                           key=f"{key}.nodes" if g.nodes else key)
        prefix = safe_name(g.prefix or Path(g.file).stem)
        mat_names: dict[int | None, str] = {}
        for r in refs:
            if r.material in mat_names:
                continue
            if r.material is None:
                params, label = {"base_color": [1.0, 1.0, 1.0], "metallic": 1.0,
                                 "roughness": 1.0, "anisotropy": 0.0}, "default"
            else:
                if not 0 <= r.material < len(asset.materials):
                    raise BadInput("no such material", file=g.file,
                                   key=f"meshes[{r.mesh}].primitives[{r.primitive}].material")
                m = asset.materials[r.material]
                params, label = m.params(), safe_name(m.name)
                if m.textures:
                    print(f"sgpipe: note: {Path(g.file).name}: materials[{m.index}] "
                          f"({m.name}): {_texture_note(m.textures)}", file=sys.stderr)
            name = _unique(f"{prefix}.{label}", materials, str(r.material))
            mat_names[r.material] = name
            cfg.fit.materials.append(MaterialSpec(name=name, model="gltf_pbr", params=params))
        for r in refs:
            name = _unique(f"{prefix}.{safe_name(r.node_name)}.{r.primitive}", objects,
                           f"n{r.node}")
            scene.objects.append(ObjectSpec(
                name=name, mesh=g.file, gltf_node=r.node, gltf_primitive=r.primitive,
                translate=g.translate, rotate_deg=g.rotate_deg, scale=g.scale,
                material=mat_names[r.material]))
