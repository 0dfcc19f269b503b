"""data_samples/textured_ball.glb: a glTF 2.0 metal-rough asset with spatially varying
reflectance, written with pygltflib (deterministic: fixed arithmetic, 8-bit PNGs, sorted JSON).

The unit UV sphere of sample_meshes (lat-long UVs) carries three 256 × 128 textures:
- base colour (sRGB): 8 × 4 tiles of four paint colours;
- metallic-roughness: roughness (G) rising linearly along u from 0.05 to 0.8, metalness (B) 1 in
  the bands v ∈ [1/4, 1/2) and [3/4, 1) and 0 elsewhere (sharp boundaries);
- normal (linear, green = +v): the 4 × 4 round bumps of normal_map.png at 128².
The material's factors are 1, so the texels are the values.
"""

from __future__ import annotations

import io
import json

import numpy as np

TEX_W, TEX_H = 256, 128
PAINTS = ((200, 40, 30), (230, 180, 40), (40, 90, 200), (235, 235, 230))   # sRGB 8-bit
ROUGHNESS = (0.05, 0.8)


def base_colour() -> np.ndarray:
    """(H, W, 3) uint8, row 0 at the top (glTF v = 0)."""
    col = np.arange(TEX_W) * 8 // TEX_W
    row = np.arange(TEX_H) * 4 // TEX_H
    idx = (col[None, :] + row[:, None]) % 4
    return np.asarray(PAINTS, np.uint8)[idx]


def metal_rough() -> np.ndarray:
    """(H, W, 3) uint8: R unused (255), G roughness along u, B metalness bands along v.
    Rows count from the top (glTF v = 0 at row 0); sgpipe's v = 1 − glTF's."""
    u = (np.arange(TEX_W) + 0.5) / TEX_W
    g = np.floor((ROUGHNESS[0] + (ROUGHNESS[1] - ROUGHNESS[0]) * u) * 255.0 + 0.5)
    v = (np.arange(TEX_H) + 0.5) / TEX_H            # glTF v at the row's centre
    b = np.where(((v >= 0.25) & (v < 0.5)) | (v >= 0.75), 255, 0)
    out = np.empty((TEX_H, TEX_W, 3), np.uint8)
    out[..., 0] = 255
    out[..., 1] = g[None, :].astype(np.uint8)
    out[..., 2] = b[:, None].astype(np.uint8)
    return out


def _png(img: np.ndarray) -> bytes:
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, "PNG", optimize=False, compress_level=9)
    return buf.getvalue()


def write_textured_ball(path, sphere, normal_rgb8: np.ndarray) -> dict:
    """Write the asset; `sphere` = (positions, faces, normals, uvs) of sample_meshes.uv_sphere
    (uvs in OBJ's convention, flipped to glTF's here); returns its facts."""
    import pygltflib as g

    from sgpipe.io.gltf_buffer import GltfBuffer
    v, f, n, uv = sphere
    pos = (np.round(np.asarray(v, np.float64), 6) + 0.0).astype(np.float32)
    nrm = (np.round(np.asarray(n, np.float64), 6) + 0.0).astype(np.float32)
    tex = np.stack([np.asarray(uv, np.float64)[:, 0], 1.0 - np.asarray(uv, np.float64)[:, 1]],
                   -1)
    tex = (np.round(tex, 6) + 0.0).astype(np.float32)
    idx = np.asarray(f, np.uint32).ravel()
    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator="sgpipe tools/sample_gltf.py"),
        scene=0, scenes=[g.Scene(nodes=[0])], nodes=[g.Node(name="ball", mesh=0)],
        samplers=[g.Sampler(wrapS=g.REPEAT, wrapT=g.CLAMP_TO_EDGE)],
        textures=[g.Texture(source=k, sampler=0) for k in range(3)],
        extensionsUsed=[], extensionsRequired=[])
    buf = GltfBuffer(doc)
    attrs = g.Attributes(POSITION=buf.accessor(pos, g.VEC3, g.ARRAY_BUFFER, minmax=True),
                         NORMAL=buf.accessor(nrm, g.VEC3, g.ARRAY_BUFFER),
                         TEXCOORD_0=buf.accessor(tex, g.VEC2, g.ARRAY_BUFFER))
    ind = buf.accessor(idx, g.SCALAR, g.ELEMENT_ARRAY_BUFFER)
    doc.images = [g.Image(bufferView=buf.view(_png(img)), mimeType="image/png")
                  for img in (base_colour(), metal_rough(), normal_rgb8)]
    doc.meshes = [g.Mesh(name="ball", primitives=[g.Primitive(attributes=attrs, indices=ind,
                                                                material=0)])]
    doc.materials = [g.Material(
        name="painted_metal",
        pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=1.0, roughnessFactor=1.0,
            baseColorTexture=g.TextureInfo(index=0),
            metallicRoughnessTexture=g.TextureInfo(index=1)),
        normalTexture=g.NormalMaterialTexture(index=2))]
    buf.embed()
    data = b"".join(doc.save_to_bytes())
    path.write_bytes(data)
    json.loads(doc.to_json())                        # well-formed
    return {"vertices": len(pos), "faces": len(f), "texture_size": [TEX_W, TEX_H],
            "roughness_range": list(ROUGHNESS)}
