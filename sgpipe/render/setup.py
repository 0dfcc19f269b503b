"""Assemble a `Renderer` and the traced scene from a config and the upstream artifacts on disk
(`<out>/envmap/`, `<out>/fit/<material>/`, `<out>/visibility/<object>/`)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from sgpipe.brdf import frame_rotation
from sgpipe.errors import BadInput
from sgpipe.io import read_data_image, read_exr
from sgpipe.render.envdata import EnvData
from sgpipe.render.materials import Material, pack_materials
from sgpipe.render.methods import PUBLISHED_SWITCHES, Method
from sgpipe.render.renderer import Light, ObjectShading, Renderer, Textures
from sgpipe.render.scene import load_trace_objects, load_vis_objects
from sgpipe.scene.gbuffer import TraceObject


@dataclass
class SceneBundle:
    renderer: Renderer
    objects: list[TraceObject]
    proxies: list            # per object: icosphere TraceObject for sphere SSDF lookup, or None
    env_latlong: np.ndarray | None   # (H, W, 3) linear radiance × exposure (background, reference)


def lights_of(rs) -> list[Light]:
    """Config lights → renderer lights (direction normalised)."""
    out = []
    for L in rs.lights:
        if L.type == "point":
            out.append(Light("point", tuple(L.position), tuple(L.intensity), L.radius))
        else:
            d = np.asarray(L.direction, float)
            out.append(Light("directional", tuple(d / np.linalg.norm(d)), tuple(L.intensity),
                             L.radius))
    return out


def read_texture(path, key) -> np.ndarray:
    """A texture or environment image (H, W, 3) float32 as the methods read it: EXR/HDR linear,
    8/16-bit images as values in [0, 1] (no sRGB decoding), one channel repeated to three."""
    return _image(path, key)


def _image(path, key) -> np.ndarray:
    img = read_exr(path, channels=(1, 3, 4), key=key) if str(path).lower().endswith(
        (".exr", ".hdr")) else _read_ldr(path, key)
    return img[..., :3] if img.shape[2] >= 3 else np.repeat(img[..., :1], 3, axis=2)


def _read_ldr(path, key) -> np.ndarray:
    """8/16-bit images (PNG) as linear values in [0, 1] (no sRGB decoding: data textures)."""
    return read_data_image(path, key)[0]


def build_scene(cfg, out_dir: str | Path, methods: list[Method]) -> SceneBundle:
    """Everything the shading `methods` need, read from `out_dir`'s upstream stage folders."""
    out_dir = Path(out_dir)
    rs = cfg.render
    if cfg.scene is None or not cfg.scene.objects:
        raise BadInput("the scene has no objects to render", key="scene.objects")
    toral19 = any(x.name == "gmm_toral19" for x in methods)
    env = (EnvData.constant(0.0) if cfg.envmap is None
           else EnvData.load(out_dir / "envmap", dual_paraboloid=toral19))
    vis_dir = out_dir / "visibility" if cfg.visibility is not None else None
    if vis_dir is not None and not vis_dir.is_dir():
        raise BadInput("visibility artifacts not found (run `sgpipe precompute` first)",
                       file=vis_dir, key="visibility")
    objects = load_trace_objects(cfg, vis_dir)
    vis = load_vis_objects(cfg, vis_dir)
    specs = object_material_specs(cfg)
    textures = Textures()
    tex_by_mat = {t.material: t for t in rs.material_textures}
    defined = {m.name for m in (cfg.fit.materials if cfg.fit is not None else [])}
    for name in tex_by_mat:
        if name not in defined:
            raise BadInput(f"material {name!r} is not defined in fit.materials",
                           key="render.material_textures")
    names, mats = [], []
    # gmm_toral19 reads Töral19's published per-view fit (one material's mixtures, no
    # per-pixel ones) unless `fit` is given back
    published_gmm = toral19 and "fit" not in rs.gmm_toral19_adds
    assets: dict = {}           # glTF files, read once for all their primitives' objects
    for o, spec in zip(cfg.scene.objects, specs):
        if o.material in names:
            continue
        m = Material.load(out_dir / "fit" / o.material, o.material,
                          need_gmm=any(x.needs_view_gmm for x in methods),
                          need_gmm_toral19=published_gmm)
        if any(x.needs_ndf_table for x in methods):
            m.tabulate_ndf(material_brdf(spec))
        t = tex_by_mat.get(o.material)
        if t is not None and t.kd_map:
            m.kd_texture = textures.add(_image(t.kd_map, "render.material_textures.kd_map"),
                                        mip=True)
        if t is not None and t.ks_map:
            m.ks_texture = textures.add(_image(t.ks_map, "render.material_textures.ks_map"),
                                        mip=True)
        m.gltf = _gltf_factors(gltf_textures(cfg, o, assets), textures)
        m.frame_rotation = frame_rotation(spec)
        m.emission, etex = emission_of(cfg, spec, o, assets)
        if etex is not None:
            m.emission_texture = textures.add(etex.image, mip=True, wrap=etex.wrap,
                                              matrix=etex.matrix)
        names.append(o.material)
        mats.append(m)
    from sgpipe.render.energy import adopt_grid_lobes, attach_energy
    for m in mats:                   # whichever methods run: they read the same lobes
        adopt_grid_lobes(m)
    if any(x.name in ("sg", "sg_wang09") or x.needs_normalmap for x in methods):
        attach_energy(mats)          # sg's energy tables of GGX materials (the normal-map
        #                              methods' bare GGX lobes under the environment, too)
    shading = []
    for k, o in enumerate(cfg.scene.objects):
        nmap = -1
        if o.normal_map is not None:
            nmap = textures.add(_image(o.normal_map, f"scene.objects.{k}.normal_map"))
        elif (nt := gltf_normal_texture(cfg, o, assets)) is not None:
            nmap = textures.add(nt.image, wrap=nt.wrap, matrix=nt.matrix)
        shading.append(ObjectShading(material=names.index(o.material), vis=vis[k][0],
                                     normal_map=nmap))
    renderer = Renderer(env=env, materials=pack_materials(mats), objects=shading,
                        textures=textures, lights=lights_of(rs), env_scale=environment_scale(cfg),
                        fh_mode=rs.fh, gmm_taps=rs.gmm_taps,
                        gmm_carry=rs.gmm_carry, gmm_points=rs.gmm_points,
                        **{f"{m}_adds": tuple(getattr(rs, f"{m}_adds"))
                           for m in PUBLISHED_SWITCHES},
                        materials_toral19=pack_materials(
                            [replace(m, gmm=m.gmm_toral19, gmm_rough=None) for m in mats])
                        if published_gmm else None)
    if any(x.needs_transport for x in methods):
        from sgpipe.render.transport_data import attach_transport
        attach_transport(renderer, cfg, out_dir, [v for v, _ in vis])
    if any(x.needs_normalmap for x in methods):
        from sgpipe.render.normalmap_data import attach_normalmaps, load_normalmap_data
        # per object: is its material a textured glTF one (the kernels' per-pixel record)?
        textured = [(g := mats[names.index(o.material)].gltf) is not None
                    and (g.base_texture >= 0 or g.metal_rough_texture >= 0)
                    for o in cfg.scene.objects]
        fitted = [mats[names.index(o.material)] for o in cfg.scene.objects]
        attach_normalmaps(renderer, load_normalmap_data(cfg, out_dir, specs, textured, fitted))
    return SceneBundle(renderer, objects, [p for _, p in vis], environment_latlong(cfg))


def _gltf_factors(found, textures: Textures):
    """A textured glTF material (gltf_textures' triple, or None) as the kernels' GltfFactors,
    its textures added to `textures` with their MIP chains, wrap modes and transforms."""
    if found is None:
        return None
    from sgpipe.render.materials import GltfFactors
    spec, base, mr, aniso = found
    g = GltfFactors.of_params(spec.params)
    if aniso is not None:           # linear data: direction (RG) and strength (B)
        g.anisotropy_texture = textures.add(aniso.image, mip=True, wrap=aniso.wrap,
                                            matrix=aniso.matrix)
    lin = linear_parameters(g, base, mr) if base is not None or mr is not None else None
    if lin is not None:
        (a, b), tex = lin
        g.base_texture = textures.add(a, mip=True, wrap=tex.wrap, matrix=tex.matrix)
        g.metal_rough_texture = textures.add(b, mip=True, wrap=tex.wrap, matrix=tex.matrix)
        g.linear = True
        return g
    for tex, slot in ((base, "base_texture"), (mr, "metal_rough_texture")):
        if tex is not None:
            setattr(g, slot, textures.add(tex.image, mip=True, wrap=tex.wrap,
                                          matrix=tex.matrix))
    return g


def linear_parameters(g, base, mr):
    """Per texel the glTF BRDF's linear parameters, ((kd, ln roughness) (H, W, 4), (F0,
    metallic)), with the texture whose grid they share, or None where the two textures'
    images, wraps or transforms differ. The BRDF is linear in kd = (1 − m)c and F0 = lerp(0.04,
    c, m) (for a given roughness), so a footprint's average of these is the average of the
    BRDF, where averages of c and m form products that differ from it wherever colour and
    metalness change together (filtering the maps of a metal band on a painted tile). The
    metallic channel lets the kernels recover each texel's c and m where they read a point
    (gltf_record.h gltf_point_params: the finest level, as the reference reads it)."""
    from sgpipe.brdf.base import GLTF_DIELECTRIC_F0
    from sgpipe.brdf.models import GLTF_MIN_ROUGHNESS
    if base is not None and mr is not None and (
            base.image.shape[:2] != mr.image.shape[:2] or tuple(base.wrap) != tuple(mr.wrap)
            or (base.matrix is None) != (mr.matrix is None)
            or (base.matrix is not None and not np.array_equal(base.matrix, mr.matrix))):
        return None
    tex = base if base is not None else mr
    h, w = tex.image.shape[:2]
    c = np.broadcast_to(g.base_color, (h, w, 3)).astype(np.float64)
    if base is not None:
        c = c * base.image[..., :3]
    metal = np.full((h, w), g.metallic)
    rough = np.full((h, w), g.roughness)
    if mr is not None:
        rough = rough * mr.image[..., 1]
        metal = metal * mr.image[..., 2]
    metal = np.clip(metal, 0.0, 1.0)[..., None]
    # roughness as ln r (r ≥ GLTF_MIN_ROUGHNESS, as the BRDF clamps it): a footprint mixing
    # smooth and rough texels reads their geometric mean, the shinier compromise (a mixture of
    # a sharp and a broad lobe keeps the sharp one's highlight)
    log_r = np.log(np.maximum(np.clip(rough, 0.0, 1.0), GLTF_MIN_ROUGHNESS))
    a = np.concatenate([(1.0 - metal) * c, log_r[..., None]], -1)
    b = np.concatenate([(1.0 - metal) * GLTF_DIELECTRIC_F0 + metal * c, metal], -1)
    return (a, b), tex


def _gltf_material(cfg, obj, assets: dict):
    """(material spec, glTF asset, glTF material index) of an object that is one glTF
    primitive (gltf_node and gltf_primitive set) rendered with a `gltf_pbr` material, else
    None. `assets`: glTF files read so far, by path."""
    if obj.gltf_node is None or obj.gltf_primitive is None or cfg.fit is None:
        return None
    spec = next((m for m in cfg.fit.materials if m.name == obj.material), None)
    if spec is None or spec.model != "gltf_pbr":
        return None
    from sgpipe.io.gltf import read_gltf
    if obj.mesh not in assets:
        assets[obj.mesh] = read_gltf(obj.mesh)
    asset = assets[obj.mesh]
    ref = next((r for r in asset.primitives
                if (r.node, r.primitive) == (obj.gltf_node, obj.gltf_primitive)), None)
    if ref is None or ref.material is None:
        return None
    return spec, asset, ref.material


def normal_mapped(cfg) -> list[bool]:
    """Per scene object: does it carry a normal map (its own `normal_map`, or its glTF
    material's normal texture)?"""
    assets: dict = {}

    def gltf_map(o):
        found = _gltf_material(cfg, o, assets)
        return found is not None and found[1].doc.materials[found[2]].normalTexture is not None
    return [o.normal_map is not None or gltf_map(o)
            for o in (cfg.scene.objects if cfg.scene is not None else [])]


def gltf_normal_texture(cfg, obj, assets: dict):
    """The normal texture of an object's glTF material (as `_gltf_material`), its `scale`
    applied to the stored texels (c' = ((2c − 1)(s, s, 1) + 1) / 2, so that the decode
    n = normalize(2c' − 1) of every method is the specification's), or None."""
    found = _gltf_material(cfg, obj, assets)
    if found is None:
        return None
    from sgpipe.io.gltf_textures import material_texture
    _, asset, index = found
    tex = material_texture(asset, index, "normalTexture")
    if tex is None:
        return None
    scale = getattr(asset.doc.materials[index].normalTexture, "scale", None)
    scale = 1.0 if scale is None else float(scale)
    if scale != 1.0:
        tex.image[..., :2] = ((2.0 * tex.image[..., :2] - 1.0) * scale + 1.0) * 0.5
    return tex


def emission_of(cfg, spec, obj, assets: dict):
    """(emitted radiance (3,): a `gltf_pbr` material's `emissive`, its glTF material's
    emissive texture (sRGB-decoded) or None): what the surface emits is their product."""
    e = np.zeros(3)
    if spec.model == "gltf_pbr":
        e = np.broadcast_to(np.asarray((spec.params or {}).get("emissive", 0.0), float),
                            (3,)).copy()
    if not e.any():
        return e, None
    found = _gltf_material(cfg, obj, assets)
    if found is None:
        return e, None
    from sgpipe.io.gltf_textures import material_texture
    return e, material_texture(found[1], found[2], "emissiveTexture")


def gltf_textures(cfg, obj, assets: dict):
    """The textured glTF material of an object that is one glTF primitive rendered with a
    `gltf_pbr` material: (its material spec, the glTF material's base-colour,
    metallic-roughness and KHR_materials_anisotropy GltfTextures, any of them None), or None
    when the material has none of them. `assets`: glTF files read so far, by path."""
    found = _gltf_material(cfg, obj, assets)
    if found is None:
        return None
    spec, asset, index = found
    from sgpipe.io.gltf_textures import ANISOTROPY_TEXTURE, material_texture
    base = material_texture(asset, index, "baseColorTexture")
    mr = material_texture(asset, index, "metallicRoughnessTexture")
    aniso = material_texture(asset, index, ANISOTROPY_TEXTURE)
    if base is None and mr is None and aniso is None:
        return None
    return spec, base, mr, aniso


def environment_scale(cfg) -> float:
    """The environment's radiance scale of every method: 2^render.environment_exposure."""
    return float(2.0 ** cfg.render.environment_exposure)


def environment_latlong(cfg) -> np.ndarray | None:
    """The config's lat-long environment × environment_scale (background, reference), or None."""
    if cfg.envmap is None:
        return None
    return _image(cfg.envmap.environment, "envmap.environment") * environment_scale(cfg)


def object_material_specs(cfg) -> list:
    """Per scene object its `fit.materials` entry (an undefined one is BadInput naming it)."""
    specs = {m.name: m for m in (cfg.fit.materials if cfg.fit is not None else [])}
    out = []
    for k, o in enumerate(cfg.scene.objects if cfg.scene is not None else []):
        if o.material not in specs:
            raise BadInput(f"material {o.material!r} is not defined in fit.materials",
                           file=cfg.source, key=f"scene.objects.{k}.material")
        out.append(specs[o.material])
    return out


def material_brdf(spec):
    """The `sgpipe.brdf` BRDF of a material spec (exact D for fis, the reference's BRDF)."""
    from sgpipe.brdf import brdf_from_spec
    try:
        return brdf_from_spec(spec)
    except (ValueError, TypeError) as e:
        raise BadInput(f"cannot build BRDF {spec.model!r}: {e}",
                       key=f"fit.materials.{spec.name}") from None


def latlong_lookup(latlong: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Radiance of the lat-long texel containing each direction (piecewise constant, CONVENTIONS)."""
    from sgpipe.core.maps import dir_to_latlong
    h, w = latlong.shape[:2]
    u, v = dir_to_latlong(np.asarray(dirs, float))
    j = np.clip((u * w).astype(int), 0, w - 1)
    i = np.clip((v * h).astype(int), 0, h - 1)
    return latlong[i, j].astype(np.float32)
