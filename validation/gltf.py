"""glTF `gltf_pbr` materials mapped onto Mitsuba 3, and the generated glTF asset that checks
textured roughness.

Mitsuba 3.9 has no Schlick Fresnel and no glTF diffuse (1 − F)·c/π, so the mappable glTF
material is a white metal: metallic 1 (factor × texture B), base colour 1 (factor × texture):
F0 = 1 makes Schlick's F ≡ 1, and what remains is GGX with α = max(roughness, 0.06)² per texel
→ `roughconductor` (material none) with a bitmap `alpha`. sgpipe interpolates the roughness
texel bilinearly and squares it; Mitsuba interpolates the squared texels: on a smooth texture
the two differ by at most (Δr_u + Δr_v)²/4 (Δr the steps between neighbouring texels), ~10⁻⁵
in α on the generated asset. The one difference left is the masking-shadowing term: the glTF BRDF's
height-correlated Smith G2 = 1/(1 + Λ(o) + Λ(i)) against Mitsuba's separable
G1(o)·G1(i) = 1/((1 + Λ(o))(1 + Λ(i))), larger by ≤ Λ(o)Λ(i)/(1 + Λ(o) + Λ(i)): it matters only
where both directions are grazing on a rough texel (docs/VALIDATION.md gives the measured gap).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from validation.conventions import Unmappable
from validation.textures import bitmap_dict, bitmap_for_mitsuba

#: the generated asset's metallic-roughness texture (width × height; roughness in G)
ROUGH_W, ROUGH_H = 256, 128


def roughness_field(u, v) -> np.ndarray:
    """Roughness of the generated asset at glTF (u, v): smooth, periodic in both (so repeat
    addressing has no seam), and without mirror symmetry in either axis (a flipped or shifted
    lookup shows); 0.18–0.66, α = r² 0.03–0.44."""
    return (0.42 + 0.12 * np.cos(2 * np.pi * u) + 0.08 * np.sin(2 * np.pi * u)
            + 0.1 * np.sin(2 * np.pi * v))


def rough_metal_texture() -> np.ndarray:
    """(H, W, 3) uint8, row 0 at glTF v = 0: R 255 (unused), G roughness, B metalness 255."""
    u = (np.arange(ROUGH_W) + 0.5) / ROUGH_W
    v = (np.arange(ROUGH_H) + 0.5) / ROUGH_H
    g = np.floor(roughness_field(u[None, :], v[:, None]) * 255.0 + 0.5)
    out = np.full((ROUGH_H, ROUGH_W, 3), 255, np.uint8)
    out[..., 1] = g.astype(np.uint8)
    return out


def write_rough_metal_ball(path: Path) -> None:
    """A .glb: data_samples/sphere.obj (its smooth normals and lat-long UVs) with one white
    metal material (base colour 1, metallic 1, roughness factor 1) and the textured roughness
    of `rough_metal_texture`; written with pygltflib, 8-bit PNG, deterministic bytes."""
    import pygltflib as g
    from PIL import Image

    from sgpipe.io.gltf_buffer import GltfBuffer
    from sgpipe.io.mesh import _read_mesh_file
    root = Path(__file__).resolve().parents[1]
    pos, faces, nrm, uv = _read_mesh_file(root / "data_samples" / "sphere.obj", None)
    tex = np.stack([uv[:, 0], 1.0 - uv[:, 1]], -1)          # OBJ's v = 0 bottom → glTF's top
    arrays = [np.asarray(pos, np.float32), np.asarray(nrm, np.float32),
              np.asarray(tex, np.float32)]
    png = io.BytesIO()
    Image.fromarray(rough_metal_texture()).save(png, "PNG", optimize=False, compress_level=9)
    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator="sgpipe validation/gltf.py"),
        scene=0, scenes=[g.Scene(nodes=[0])], nodes=[g.Node(name="ball", mesh=0)],
        meshes=[g.Mesh(name="ball", primitives=[g.Primitive(
            attributes=g.Attributes(POSITION=0, NORMAL=1, TEXCOORD_0=2), indices=3,
            material=0)])],
        materials=[g.Material(name="rough_metal", pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=1.0, roughnessFactor=1.0,
            metallicRoughnessTexture=g.TextureInfo(index=0)))],
        samplers=[g.Sampler(wrapS=g.REPEAT, wrapT=g.REPEAT)],
        textures=[g.Texture(source=0, sampler=0)])
    buf = GltfBuffer(doc)
    for k, (a, kind) in enumerate(zip(arrays, (g.VEC3, g.VEC3, g.VEC2))):   # accessors 0–2
        buf.accessor(a, kind, g.ARRAY_BUFFER, minmax=k == 0)
    buf.accessor(np.asarray(faces, np.uint32).ravel(), g.SCALAR, g.ELEMENT_ARRAY_BUFFER)
    doc.images = [g.Image(bufferView=buf.view(png.getvalue()), mimeType="image/png")]
    buf.embed()
    Path(path).write_bytes(b"".join(doc.save_to_bytes()))


def _all_one(value, texture, channels) -> bool:
    v = np.asarray(value, float)
    if texture is not None:
        v = v * np.asarray(texture.image, float)[..., channels]
    return bool(np.all(np.abs(v - 1.0) <= 1e-6))


def gltf_bsdf_dict(spec, textures) -> dict:
    """Mitsuba BSDF of a `gltf_pbr` material spec and its glTF textures (render.setup.
    gltf_textures: (spec, base colour, metallic-roughness) or None): a two-sided roughconductor
    GGX, material none, alpha = max(roughness, 0.06)² (a bitmap when the roughness is
    textured). Anything else (a dielectric part, a coloured metal, anisotropy, emission, a
    texture transform or mixed wrap modes) is Unmappable."""
    from sgpipe.brdf.models import GLTF_MIN_ROUGHNESS
    from sgpipe.io.gltf_textures import REPEAT
    p = dict(spec.params or {})
    base_tex, mr_tex = (textures[1], textures[2]) if textures is not None else (None, None)
    if float(p.get("anisotropy", 0.0)) != 0.0 or np.any(np.asarray(p.get("emissive", 0.0))):
        raise Unmappable(f"material {spec.name!r}: glTF anisotropy / emission have no Mitsuba "
                         "counterpart here")
    if not _all_one(p.get("metallic", 1.0), mr_tex, 2):
        raise Unmappable(f"material {spec.name!r}: metallic < 1 (the glTF dielectric's Schlick "
                         "Fresnel and (1 − F) diffuse have no Mitsuba counterpart)")
    if not _all_one(p.get("base_color", 1.0), base_tex, slice(0, 3)):
        raise Unmappable(f"material {spec.name!r}: base colour ≠ 1 (a coloured metal's Schlick "
                         "Fresnel has no Mitsuba counterpart)")
    for t in (base_tex, mr_tex):
        if t is not None and (t.matrix is not None or tuple(t.wrap) != (REPEAT, REPEAT)):
            raise Unmappable(f"material {spec.name!r}: a texture transform or a non-repeat "
                             "wrap mode (Mitsuba's bitmap has one wrap mode)")
    rough = float(p.get("roughness", 1.0))
    inner = {"type": "roughconductor", "distribution": "ggx", "material": "none",
             "sample_visible": True}
    if mr_tex is None:
        inner["alpha"] = max(rough, GLTF_MIN_ROUGHNESS) ** 2
    else:
        r = rough * np.asarray(mr_tex.image, float)[..., 1:2]
        inner["alpha"] = bitmap_dict(bitmap_for_mitsuba(
            np.maximum(r, GLTF_MIN_ROUGHNESS) ** 2))
    return {"type": "twosided", "bsdf": inner}
