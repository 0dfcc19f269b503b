"""Han07 Fig 2 / Fig 8's multi-material maps on a glTF asset (eq 22 with eq 21): the grooves
map as a glTF normal texture whose base colour, metalness and roughness change with the facet
orientation (base-colour and metallic-roughness textures made from the map's own normals), the
plane at 1–64× minification under the Fig 2 light, `vmf` with the material's features
(`normalmap.colour_features`: each lobe its own kd, F0 and roughness) against the same `vmf`
with the pixel's filtered material (J = 4 and 8 lobes), `vmf_han07` (eq 22 as published), the
single-lobe baselines and the reference. `python -m sgpipe.experiments.han07` runs it (its
report's "glTF material map" section); alone:

    python -m sgpipe.experiments.han07_material --out out/figures/han07_material
"""

from __future__ import annotations

import io
import math
import sys
from pathlib import Path

import numpy as np

from sgpipe.experiments import han07 as H
from sgpipe.experiments import han07_colour as HC

#: facet orientation → (base colour, sRGB; roughness; metallic): the map's ±x and ±y facets
#: and its flat tops each get their own material
CLUSTERS = (((1, 0), (0.85, 0.18, 0.10), 0.25, 0.0), ((-1, 0), (0.55, 0.65, 0.95), 0.6, 1.0),
            ((0, 1), (0.15, 0.80, 0.15), 0.7, 0.0), ((0, -1), (0.95, 0.80, 0.35), 0.2, 1.0))
FLAT = ((0.5, 0.5, 0.5), 0.5, 0.0)


def material_images(normal_map: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(normal texels, base colour (sRGB), metallic-roughness (G roughness, B metallic)) of
    the map's facet clusters (CLUSTERS), each (n, n, 3) in [0, 1]."""
    from sgpipe.normalmap.read import decode_normals, read_normal_texels
    texels = read_normal_texels(normal_map, "normal_map")
    n = decode_normals(texels)
    base = np.tile(np.asarray(FLAT[0]), n.shape[:2] + (1,))
    mr = np.tile(np.asarray([0.0, FLAT[1], FLAT[2]]), n.shape[:2] + (1,))
    for (ax, ay), c, r, m in CLUSTERS:
        sel = ax * n[..., 0] + ay * n[..., 1] > 0.3
        base[sel], mr[sel] = c, (0.0, r, m)
    return np.asarray(texels, float)[..., :3], base, mr


def _png(img: np.ndarray) -> bytes:
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(np.round(np.clip(img, 0, 1) * 255).astype(np.uint8)).save(buf, "PNG")
    return buf.getvalue()


def plane_glb(path: Path, rep: float, images: tuple) -> Path:
    """The Fig 2 plane (floor.obj's 6 × 6 in y = 0 facing +y, u along +x, v along −z, the
    textures repeated `rep` times across it) as a .glb whose one material carries the normal,
    base-colour and metallic-roughness textures `images` (factors 1, REPEAT samplers)."""
    import pygltflib as g

    from sgpipe.io.gltf_buffer import GltfBuffer
    p = np.array([[-3, 0, 3], [3, 0, 3], [3, 0, -3], [-3, 0, -3]], np.float32)
    nrm = np.tile(np.float32([0, 1, 0]), (4, 1))
    uv = np.array([[0, 0], [rep, 0], [rep, rep], [0, rep]], np.float32)
    st = np.stack([uv[:, 0], 1.0 - uv[:, 1]], -1).astype(np.float32)     # glTF: t = 1 − v
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    doc = g.GLTF2(asset=g.Asset(version="2.0"), scene=0, scenes=[g.Scene(nodes=[0])],
                  nodes=[g.Node(name="plane", mesh=0)],
                  textures=[g.Texture(source=k, sampler=0) for k in range(3)],
                  samplers=[g.Sampler(wrapS=g.REPEAT, wrapT=g.REPEAT)])
    buf = GltfBuffer(doc)
    attrs = g.Attributes(POSITION=buf.accessor(p, g.VEC3, g.ARRAY_BUFFER, minmax=True),
                         NORMAL=buf.accessor(nrm, g.VEC3, g.ARRAY_BUFFER, minmax=True),
                         TEXCOORD_0=buf.accessor(st, g.VEC2, g.ARRAY_BUFFER))
    ind = buf.accessor(idx, g.SCALAR, g.ELEMENT_ARRAY_BUFFER)
    doc.images = [g.Image(bufferView=buf.view(_png(im)), mimeType="image/png") for im in images]
    pbr = g.PbrMetallicRoughness(baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=1.0,
                                 roughnessFactor=1.0, baseColorTexture=g.TextureInfo(index=1),
                                 metallicRoughnessTexture=g.TextureInfo(index=2))
    doc.materials = [g.Material(name="facets", pbrMetallicRoughness=pbr,
                                normalTexture=g.NormalMaterialTexture(index=0))]
    doc.meshes = [g.Mesh(primitives=[g.Primitive(attributes=attrs, indices=ind, material=0)])]
    buf.embed()
    path.parent.mkdir(parents=True, exist_ok=True)
    doc.save_binary(str(path))
    return path


def _config(glb: Path, camera: dict, methods, features: bool, spp: int, lobes: int):
    from sgpipe.config.root import Config
    from sgpipe.config.schema import Context, build
    raw = {"name": "han07_material", "seed": 0, "scene": {"gltf": [{"file": str(glb)}]},
           "fit": {"view_gmm": {"enabled": False}},
           "normalmap": {"lobes": int(lobes), "bilinear_samples": int(H.BILINEAR_SAMPLES),
                         "colour_features": features},
           "render": {"camera": camera, "methods": list(methods), "spp": spp,
                      "background": False, "supersample": 1, "normalmap_max_taps": 8,
                      "normalmap_footprint": H.FOOTPRINT,
                      "lights": [{"type": "directional", "direction": list(H.LIGHT_PLANE),
                                  "intensity": [H.IRRADIANCE] * 3}]}}
    from sgpipe.config.gltf_scene import expand_gltf
    cfg = build(Config, raw, (), Context(file=None, lines={}))
    expand_gltf(cfg)                    # the asset's primitives and material, as load_config
    return cfg


def cell(minification: float, *, size: int, spp: int, out: Path) -> dict:
    """{column: {image, psnr, flip} or {error}, "reference": {...}} of one minification;
    columns HC.VMF_RUNS beside HC.METHODS' (`han07_colour.score_cell`)."""
    images = material_images(H.DATA / H.MAPS["grooves"])
    glb = plane_glb(out / "assets" / f"plane_m{minification:g}.glb",
                    3.0 * size * minification / 256.0, images)
    d = 1.0 / math.tan(math.radians(H.PLANE_FOV / 2))
    camera = {"eye": [0.0, d, 0.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
              "fov_deg": H.PLANE_FOV, "width": size, "height": size}
    return HC.score_cell(lambda methods, features, lobes: _config(glb, camera, methods,
                                                                  features, spp, lobes),
                         out / "runs" / f"m{minification:g}")


def run(out: Path, *, size: int = 64, spp: int = 512, minifications=H.MINIFICATIONS,
        log=print) -> dict:
    """{minification: cell}."""
    return HC.run_cells(cell, "glTF material grooves plane", out, size=size, spp=spp,
                        minifications=minifications, log=log)


def targets(rows: dict) -> list[dict]:
    """vmf with the material's features ≥ HC.TARGET_DB over the same vmf with the pixel's
    filtered material, per minification and lobe count."""
    return [{**t, "name": t["name"].replace("colour features", "material features")
             .replace("the colour's plain MIP", "the pixel's filtered material"),
             "subject": "glTF material grooves plane"} for t in HC.targets(rows)]


def section(rows: dict) -> list[str]:
    """The report's Markdown section."""
    L = ["## glTF material map (Fig 2 / Fig 8, eq 22 with eq 21)", "",
         "The grooves map as a glTF normal texture with a base colour (sRGB), roughness and "
         "metalness per facet orientation: "
         + ", ".join(f"({', '.join(f'{x:g}' for x in c)}) r {r:g} m {m:g}"
                     for _, c, r, m in CLUSTERS)
         + f" on the +x, −x, +y, −y facets, ({', '.join(f'{x:g}' for x in FLAT[0])}) r "
         f"{FLAT[1]:g} m {FLAT[2]:g} on the flat tops (`gltf_pbr`, factors 1), the plane of "
         "Fig 2 under its light. `vmf` / `vmf8`: J = 4 / 8 lobes with the material's features "
         "(`normalmap.colour_features`: each lobe its own kd, F0 and roughness); `vmf_mip` / "
         "`vmf8_mip`: the same with the pixel's filtered material (features off); "
         "`vmf_han07`: Han07 as published (J = 4). Cells: surface display PSNR (dB) / "
         "LDR-ꟻLIP against the reference.", ""]
    return L + HC.table(rows)


def main(argv=None) -> int:
    return HC.standalone(argv, sys.modules[__name__], "han07_material")


if __name__ == "__main__":
    sys.exit(main())
