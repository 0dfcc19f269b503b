"""The Mitsuba 3 scene of an sgpipe config, built through validation.conventions, and its two
renders: `filter` (Mitsuba's own sensor and film with the config's pixel filter, box by
default) and `centre` (Mitsuba's sensor sampled at the pixel centres only: what sgpipe's
`center` pixel filter traces)."""

from __future__ import annotations

import numpy as np

from validation import import_mitsuba
from validation.conventions import (Unmappable, bsdf_dict, emitter_dict, envmap_for_mitsuba,
                                    envmap_to_world, pixel_centres, rfilter_dict, sensor_params,
                                    sphere_to_world)
from validation.textures import (check_mappable, normalmap_bsdf_dict, textured_bsdf_dict)


def _mesh(mi, spec, g, bsdf):
    """A Mitsuba mesh with sgpipe's own loaded geometry (same file, transform and normals) and,
    when the file has them, its UVs × the object's uv_repeat (sgpipe.render.scene.repeated_uvs,
    what sgpipe's tracer interpolates)."""
    import drjit as dr
    from sgpipe.render.scene import repeated_uvs
    props = mi.Properties()
    props["bsdf"] = bsdf
    m = mi.Mesh(spec.name, len(g.positions), len(g.faces), props=props,
                has_vertex_normals=True, has_vertex_texcoords=bool(g.has_uvs))
    p = mi.traverse(m)
    p["vertex_positions"] = dr.ravel(mi.Point3f(*np.asarray(g.positions, np.float32).T))
    p["vertex_normals"] = dr.ravel(mi.Normal3f(*np.asarray(g.normals, np.float32).T))
    if g.has_uvs:
        uv = np.asarray(repeated_uvs(g.uvs, spec), np.float32)
        p["vertex_texcoords"] = dr.ravel(mi.Point2f(*uv.T))
    p["faces"] = dr.ravel(mi.Vector3u(*np.asarray(g.faces, np.uint32).T))
    p.update()
    return m


def _bitmaps(mi, node):
    """The dict with every validation.textures `bitmap` array ("data") made an mi.Bitmap."""
    if not isinstance(node, dict):
        return node
    out = {k: _bitmaps(mi, v) for k, v in node.items()}
    if node.get("type") == "bitmap" and isinstance(node.get("data"), np.ndarray):
        out["bitmap"] = mi.Bitmap(np.ascontiguousarray(out.pop("data"), np.float32))
    return out


def _object_bsdf(cfg, spec, brdf, has_uvs: bool) -> dict:
    """bsdf_dict of the object's material with its kd / ks textures (render.material_textures)
    and its normal map, as sgpipe's reference reads them (sgpipe.stages.render.object_maps)."""
    from sgpipe.render.setup import read_texture
    if brdf.name == "gltf_pbr":
        return _gltf_bsdf(cfg, spec, has_uvs)
    tex = {t.material: t for t in cfg.render.material_textures}.get(spec.material)
    kd_map = read_texture(tex.kd_map, "kd_map") if tex is not None and tex.kd_map else None
    ks_map = read_texture(tex.ks_map, "ks_map") if tex is not None and tex.ks_map else None
    check_mappable(spec, has_uvs=has_uvs, textured=kd_map is not None or ks_map is not None,
                   backfacing=cfg.render.reference_mapped_backfacing)
    d = textured_bsdf_dict(bsdf_dict(brdf), kd_map, ks_map)
    if spec.normal_map is not None:
        d = normalmap_bsdf_dict(d, read_texture(spec.normal_map, "normal_map"))
    return d


def _gltf_bsdf(cfg, spec, has_uvs: bool) -> dict:
    """validation.gltf's Mitsuba BSDF of a glTF primitive's `gltf_pbr` material and its
    textures, as sgpipe's reference reads them (render.setup.gltf_textures)."""
    from sgpipe.render.setup import gltf_normal_texture, gltf_textures
    from validation.gltf import gltf_bsdf_dict
    mat = next(m for m in cfg.fit.materials if m.name == spec.material)
    textures = gltf_textures(cfg, spec, {})
    if gltf_normal_texture(cfg, spec, {}) is not None:
        raise Unmappable(f"object {spec.name!r}: a glTF normal texture (its MikkTSpace frame "
                         "is not Mitsuba's per-triangle ∂p/∂u)")
    check_mappable(spec, has_uvs=has_uvs, textured=textures is not None)
    return gltf_bsdf_dict(mat, textures)


#: envmap resampling (conventions.envmap_for_mitsuba): 4× in u, 16× in v, so a lamp's edge seen
#: directly is blurred by ≤ ±1/8 texel (±0.09° on the 512-wide maps) in either direction
ENV_FACTOR = (4, 16)


def _integrator(rs) -> dict:
    """`direct` for sgpipe's direct-only reference; with `render.reference_bounces` N > 0 the
    `path` integrator with max_depth N + 2 (1: emitters seen directly, 2: direct lighting, each
    further segment one indirect bounce) and Russian roulette never reached, as sgpipe's."""
    bounces = int(getattr(rs, "reference_bounces", 0) or 0)
    if bounces == 0:
        return {"type": "direct", "hide_emitters": not rs.background}
    return {"type": "path", "max_depth": bounces + 2, "rr_depth": bounces + 3,
            "hide_emitters": not rs.background}


def _environment_rotation(rs):
    """render.environment_rotation's 3×3 world ← map matrix, or None (also for configs of an
    sgpipe without the key)."""
    spec = getattr(rs, "environment_rotation", None)
    return None if spec is None else spec.matrix()


def scene_dict(cfg, *, spp: int = 64, env_factor=ENV_FACTOR, centre: bool = False) -> dict:
    """The Mitsuba scene dict of a validated sgpipe config (see docs/VALIDATION.md); `centre`:
    for render_centre, which never uses the film's filter (box then)."""
    mi = import_mitsuba()
    from sgpipe.brdf import brdf_from_spec
    from sgpipe.io import read_exr
    from sgpipe.render.setup import environment_scale
    rs = cfg.render
    cam = sensor_params(rs.camera)
    d = {"type": "scene",
         "integrator": _integrator(rs),
         "sensor": {"type": "perspective", "fov": cam["fov"], "fov_axis": cam["fov_axis"],
                    "to_world": mi.ScalarTransform4f(cam["to_world"]),
                    "film": {"type": "hdrfilm", "width": cam["width"],
                             "height": cam["height"],
                             "rfilter": {"type": "box"} if centre else
                             rfilter_dict(getattr(rs, "pixel_filter", None) or {}),
                             "pixel_format": "rgb"},
                    "sampler": {"type": "independent", "sample_count": int(spp)}}}
    if cfg.envmap is not None:
        env = read_exr(cfg.envmap.environment, channels=(1, 3, 4), key="envmap.environment")
        env = env[..., :3] if env.shape[2] >= 3 else np.repeat(env[..., :1], 3, axis=2)
        d["environment"] = {"type": "envmap",
                            "bitmap": mi.Bitmap(envmap_for_mitsuba(env, *env_factor)),
                            "scale": environment_scale(cfg),
                            "to_world": mi.ScalarTransform4f(envmap_to_world(
                                _environment_rotation(rs)))}
    from sgpipe.io.mesh import load_object
    mats = {m.name: m for m in cfg.fit.materials}
    for k, spec in enumerate(cfg.scene.objects):
        brdf = brdf_from_spec(mats[spec.material])
        if spec.sphere_radius is not None:
            bsdf = _bitmaps(mi, _object_bsdf(cfg, spec, brdf, False))
            d[f"obj_{k}"] = {"type": "sphere", "bsdf": bsdf, "to_world": mi.ScalarTransform4f(
                sphere_to_world(spec.translate, spec.sphere_radius * spec.scale))}
        else:
            g = load_object(spec, k)
            bsdf = _bitmaps(mi, _object_bsdf(cfg, spec, brdf, bool(g.has_uvs)))
            d[f"obj_{k}"] = _mesh(mi, spec, g, mi.load_dict(bsdf))
    for k, light in enumerate(rs.lights):
        d[f"light_{k}"] = emitter_dict(light)
    return d


def load_scene(cfg, *, spp: int = 64, env_factor=ENV_FACTOR, centre: bool = False):
    mi = import_mitsuba()
    return mi.load_dict(scene_dict(cfg, spp=spp, env_factor=env_factor, centre=centre))


def render_filter(scene, spp: int, seed: int = 0, passes: int = 1) -> np.ndarray:
    """Mitsuba's own render (its film's reconstruction filter), mean of `passes` renders of
    spp each with seeds seed·passes + k, (H, W, 3) float64."""
    mi = import_mitsuba()
    acc = None
    for k in range(passes):
        img = np.asarray(mi.render(scene, spp=int(spp), seed=int(seed * passes + k)), np.float64)
        acc = img if acc is None else acc + img
    return acc[..., :3] / passes


def render_centre(scene, spp: int, seed: int = 0, spp_per_pass: int = 16) -> np.ndarray:
    """Mitsuba's integrator on rays of its sensor through the pixel centres only, (H, W, 3)."""
    mi = import_mitsuba()
    import drjit as dr
    sensor = scene.sensors()[0]
    size = sensor.film().crop_size()
    w, h = int(size[0]), int(size[1])
    xy = pixel_centres(w, h).reshape(-1, 2)
    integrator = scene.integrator()
    acc = np.zeros((h * w, 3))
    done, k = 0, 0
    while done < spp:
        n = min(spp_per_pass, spp - done)
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(int(seed) * 100003 + k, h * w * n)
        pos = mi.Point2f(np.repeat(xy[:, 0], n).astype(np.float32),
                         np.repeat(xy[:, 1], n).astype(np.float32))
        ray, weight = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
        spec, _, _ = integrator.sample(scene, sampler, ray)
        rgb = spec * weight
        dr.eval(rgb)
        arr = np.stack([np.asarray(rgb[c], np.float64) for c in range(3)], -1)
        acc += arr.reshape(h * w, n, 3).sum(1)
        done += n
        k += 1
    return (acc / spp).reshape(h, w, 3)
