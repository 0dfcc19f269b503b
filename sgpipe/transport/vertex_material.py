"""Per-vertex materials of the transport stage (Green06 Fig 1: a surface whose material varies
from diffuse to specular, its eq 2 transport T_{x,v} = f_s,x V_x cos fitted per vertex x with
that vertex's own BRDF f_s,x): a textured glTF metal-rough material's base-colour and
metallic-roughness textures filtered to the vertex spacing, read at each vertex.

    vm = vertex_materials(found, geometry)     # found: render.setup.gltf_textures' tuple
    vm.brdf_params(i)                          # make_brdf("gltf_pbr", ...) of vertex i

What is filtered is what the renderer filters per pixel (shading.h gltf_pixel_record): where
the two textures share a grid, the BRDF's linear parameters kd = (1 − m) c, F0 = lerp(0.04, c,
m) and ln roughness per texel (render.setup.linear_parameters), else the base colour and the
metallic-roughness texels, F0 formed from their filtered values. The transport holds the
specular lobe only (the diffuse part is the SH transfer, coloured per pixel by the renderer), so
a vertex's BRDF is the gltf_pbr of base colour F0, metallic 1 and the filtered roughness: the
same specular f_s as the vertex's (c, m), which the filtered (kd, F0) need not have.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sgpipe.brdf.base import GLTF_DIELECTRIC_F0
from sgpipe.brdf.models import GLTF_MIN_ROUGHNESS
from sgpipe.io.gltf_textures import GltfTexture


@dataclass
class VertexMaterials:
    """Per vertex (X rows) the filtered gltf_pbr parameters: diffuse kd (X, 3), Schlick F0
    (X, 3), roughness (X,)."""

    kd: np.ndarray
    f0: np.ndarray
    roughness: np.ndarray

    def brdf_params(self, i: int) -> dict:
        """gltf_pbr params whose specular lobe is vertex i's (base colour F0, metallic 1)."""
        return {"base_color": [float(x) for x in np.clip(self.f0[i], 0.0, 1.0)],
                "metallic": 1.0, "roughness": float(np.clip(self.roughness[i], 0.0, 1.0))}

    def rows(self, idx) -> "VertexMaterials":
        """The materials of the vertices idx (a chunk's, in its order)."""
        return VertexMaterials(self.kd[idx], self.f0[idx], self.roughness[idx])


def _texel_jacobian(tex: GltfTexture) -> np.ndarray:
    """2×2 map from an sgpipe uv step (du, dv) to level-0 texels (x, y): glTF's (s, t) =
    (u, 1 − v), the texture transform's linear part, the image size."""
    m = np.eye(2) if tex.matrix is None else np.asarray(tex.matrix, float)[:2, :2]
    h, w = tex.image.shape[:2]
    return np.diag([w, h]) @ m @ np.diag([1.0, -1.0])


def vertex_footprint(uvs, faces, tex: GltfTexture) -> np.ndarray:
    """(X,) per vertex the mean length, in level-0 texels of `tex`, of its mesh edges in uv."""
    f = np.asarray(faces, np.int64)
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), 1), axis=0)
    d = (np.asarray(uvs, float)[e[:, 1]] - np.asarray(uvs, float)[e[:, 0]]) @ \
        _texel_jacobian(tex).T
    length = np.linalg.norm(d, axis=1)
    n = len(uvs)
    total = np.bincount(e.ravel(), np.repeat(length, 2), minlength=n)
    count = np.bincount(e.ravel(), minlength=n)
    return total / np.maximum(count, 1)


def filtered_at(tex: GltfTexture, image, uvs, footprint) -> np.ndarray:
    """`image` (tex's grid, its wrap and transform) at each vertex's uv averaged over a box of
    `footprint` level-0 texels: trilinear in its MIP chain (render.textures.mip_chain, the
    renderer's box chain) at level log2(footprint)."""
    from sgpipe.render.textures import mip_chain
    levels = mip_chain(image)
    lv = np.clip(np.log2(np.maximum(footprint, 1.0)), 0.0, len(levels) - 1)
    lo = np.floor(lv).astype(np.int64)
    frac = (lv - lo)[:, None]
    out = np.zeros((len(uvs), image.shape[2]))
    for k in np.unique(lo):
        sel = lo == k
        a = GltfTexture(levels[k], tex.wrap, tex.matrix).bilinear(uvs[sel])
        b = (GltfTexture(levels[k + 1], tex.wrap, tex.matrix).bilinear(uvs[sel])
             if k + 1 < len(levels) else a)
        out[sel] = (1.0 - frac[sel]) * a + frac[sel] * b
    return out


def vertex_materials(found, geometry) -> VertexMaterials | None:
    """The per-vertex materials of an object's textured gltf_pbr material (`found`:
    render.setup.gltf_textures' (spec, base, metallic-roughness, anisotropy textures), or
    None), its mesh `geometry` (uvs, faces); None where there is nothing to vary (no base or
    metallic-roughness texture) or the material is anisotropic (its transport keeps the
    factors' BRDF)."""
    if found is None:
        return None
    spec, base, mr, aniso = found
    p = dict(spec.params or {})
    if (base is None and mr is None) or aniso is not None or float(p.get("anisotropy", 0.0)):
        return None
    from sgpipe.render.materials import GltfFactors
    from sgpipe.render.setup import linear_parameters
    g = GltfFactors(np.broadcast_to(np.asarray(p.get("base_color", 1.0), float), (3,)),
                    float(p.get("metallic", 1.0)), float(p.get("roughness", 1.0)), 0.0)
    uvs = np.asarray(geometry.uvs, float)
    faces = geometry.faces
    # Each vertex's transport spreads over its one-ring by the barycentric blend (a hat two
    # edges wide, about one edge at half height); the vertex's material is the textures
    # averaged over a box of the mean one-ring edge length, read from the MIP chain as the
    # renderer reads a pixel's footprint — finer detail than the mesh cannot be held per vertex.
    lin = linear_parameters(g, base, mr)
    if lin is not None:
        (a, b), tex = lin
        fp = vertex_footprint(uvs, faces, tex)
        va, vb = filtered_at(tex, a, uvs, fp), filtered_at(tex, b, uvs, fp)
        return VertexMaterials(va[:, :3], vb[:, :3], np.exp(va[:, 3]))
    c = np.tile(g.base_color, (len(uvs), 1))
    metal = np.full(len(uvs), g.metallic)
    rough = np.full(len(uvs), g.roughness)
    if base is not None:
        c = c * filtered_at(base, base.image, uvs, vertex_footprint(uvs, faces, base))[:, :3]
    if mr is not None:
        t = filtered_at(mr, mr.image, uvs, vertex_footprint(uvs, faces, mr))
        rough, metal = rough * t[:, 1], metal * t[:, 2]
    metal = np.clip(metal, 0.0, 1.0)[:, None]
    rough = np.maximum(np.clip(rough, 0.0, 1.0), GLTF_MIN_ROUGHNESS)
    return VertexMaterials((1.0 - metal) * c, (1.0 - metal) * GLTF_DIELECTRIC_F0 + metal * c,
                           rough)


__all__ = ["VertexMaterials", "vertex_footprint", "filtered_at", "vertex_materials"]
