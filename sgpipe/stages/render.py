"""The render stage: `cfg.render` → `<out>/render/` (docs/ARTIFACTS.md render/).

Primary visibility once (Embree G-buffer, sgpipe.scene), then every method of `render.methods`:
the OpenCL methods of the registry (sgpipe.render.methods: `sg`, `gmm`, `fis`) shade the
G-buffer; `reference` is the Monte Carlo ground truth of sgpipe.reference, reached from a config
through `reference_from_config` (the one path, also the experiments'). Each image is written as
linear EXR + PNG preview; timings go to timings.json (wall clock), image statistics and
comparisons (sgpipe.metrics) to the manifest report.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sgpipe.artifacts import render as art
from sgpipe.config.schema import to_plain
from sgpipe.errors import BadInput
from sgpipe.io.mesh import object_files
from sgpipe.stages.base import StageRun, log
from sgpipe.stages.upstream import upstream_difference

#: The stages render reads: (stage, the command that makes it, the config sections its
#: artifacts are computed from — the same its own cache key holds).
UPSTREAM = (("fit", "fit", ("fit",)), ("envmap", "precompute", ("envmap",)),
            ("visibility", "precompute", ("visibility", "scene")),
            ("transport", "precompute", ("transport", "scene", "fit.materials")),
            ("normalmap", "precompute", ("normalmap", "scene.objects.*.name",
                                         "scene.objects.*.normal_map")))


def _inputs(cfg, out_dir: Path, upstream: list[str]) -> list[Path]:
    """Upstream manifests of the stages read (they hash every artifact) and the files the
    scene names."""
    files = [out_dir / s / "manifest.json" for s in upstream]
    for o in cfg.scene.objects if cfg.scene is not None else []:
        files += object_files(o) + ([Path(o.normal_map)] if o.normal_map else [])
    for t in cfg.render.material_textures:
        files += [Path(p) for p in (t.kd_map, t.ks_map) if p]
    if cfg.envmap is not None:
        files.append(Path(cfg.envmap.environment))
    for m in cfg.fit.materials if cfg.fit is not None else []:
        if m.merl_file:
            files.append(Path(m.merl_file))
    return files


def _time_method(renderer, method, frame_dev, repeats, **kw):
    """(radiance, seconds): first launch builds; the minimum of `repeats` warm launches."""
    rgb = renderer.shade(method, frame_dev, **kw)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        rgb = renderer.shade(method, frame_dev, **kw)
        best = min(best, time.perf_counter() - t0)
    return rgb, best


def run(cfg, out_dir: Path, *, force: bool = False):
    """Run the render stage of a validated config (no-op when the section is absent)."""
    if cfg.render is None:
        log("[render] no 'render:' section in the config; nothing to do")
        return None
    from sgpipe.render.methods import METHODS, REFERENCE
    from sgpipe.render.records import KernelFlag
    from sgpipe.render.setup import build_scene, normal_mapped
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import Tracer

    out_dir = Path(out_dir)
    rs = cfg.render
    # the normalmap stage writes nothing for a scene without normal maps
    upstream = [(stage, cmd, sections) for stage, cmd, sections in UPSTREAM
                if getattr(cfg, stage) is not None
                and (stage != "normalmap" or any(normal_mapped(cfg)))]
    if cfg.normalmap is not None and cfg.normalmap.colour_features:
        # the pyramids' colour features are the material textures filtered with the normals
        upstream = [(st, cmd, sec + (("render.material_textures",) if st == "normalmap" else ()))
                    for st, cmd, sec in upstream]
    for stage, cmd, sections in upstream:
        if not (out_dir / stage / "manifest.json").is_file():
            raise BadInput(f"no {stage} artifacts here: run `sgpipe {cmd}` (or `sgpipe run`) "
                           f"with the same --out first", file=out_dir / stage, key=stage)
        # artifacts made for another config would be rendered silently as this one's
        diff = upstream_difference(cfg, out_dir, stage, sections)
        if diff:
            raise BadInput(f"was made for another config ({diff}): run `sgpipe {cmd}` (or "
                           "`sgpipe run`) with the same --out first", file=out_dir / stage,
                           key=stage)
    params = {"render": to_plain(rs), "scene": to_plain(cfg.scene),
              "materials": to_plain(cfg.fit.materials) if cfg.fit is not None else []}
    inputs = _inputs(cfg, out_dir, [stage for stage, _, _ in upstream])
    with StageRun(cfg, out_dir, "render", params=params, inputs=inputs, force=force) as run:
        if run.skipped:
            return run
        shaders = [METHODS[m] for m in rs.methods if m in METHODS]
        t0 = time.perf_counter()
        bundle = build_scene(cfg, out_dir, shaders)
        bundle.renderer.rotate_environment(rs.environment_rotation.matrix())
        run.timings["setup_s"] = time.perf_counter() - t0
        cam = Camera.from_spec(rs.camera)
        t0 = time.perf_counter()
        tracer = Tracer(bundle.objects)
        gb = tracer.trace(*cam.rays())       # the pixel centres: gbuffer.npz, surface masks
        subframes = supersampled_frames(cam, tracer, bundle, rs.supersample, rs.background,
                                        centre=gb,
                                        footprints=any(m.needs_normalmap for m in shaders)
                                        or bool(bundle.renderer.textured))
        n_shaded = int(gb.hit.sum())
        run.timings["gbuffer_s"] = time.perf_counter() - t0
        art.write_gbuffer(run, {k: getattr(gb, k) for k in art.GBUFFER_ARRAYS})
        r = bundle.renderer
        images = {}
        if shaders:
            fdevs = [r.upload_frame(fr) for fr, _ in subframes]
            mip_cov = cfg.envmap.mip_coverage if cfg.envmap is not None else 0.9
            ss = f", {rs.supersample}x{rs.supersample} supersampled" if rs.supersample > 1 else ""
            emitted = [None] * len(subframes)     # what the surfaces emit, added to each method
            if r.emissive:
                emitted = [_time_method(r, "emission", fdev, rs.timing_repeats)
                           for fdev in fdevs]
            for m in shaders:
                method = m.name
                unshadowed = m.baseline_shadows and not rs.baseline_shadows
                acc, sec = None, 0.0
                for (fr, bg), fdev, emit in zip(subframes, fdevs, emitted):
                    rgb, s_k = _time_method(
                        r, method, fdev, rs.timing_repeats, fis_samples=rs.fis_samples,
                        gmm_interpolate=rs.gmm_interpolate, mip_coverage=mip_cov,
                        flags=KernelFlag.NO_VISIBILITY if unshadowed else 0)
                    if emit is not None:
                        rgb, s_k = rgb + emit[0], s_k + emit[1]
                    img = fr.to_image(rgb, bg).astype(np.float64)
                    acc = img if acc is None else acc + img
                    sec += s_k
                images[method] = (acc / len(subframes)).astype(np.float32)
                run.timings[f"{method}_s"] = sec
                run.timings[f"{method}_fps"] = 1.0 / sec if sec > 0 else float("inf")
                log(f"[render] {method}: {sec * 1e3:.1f} ms/frame "
                    f"({cam.width}x{cam.height}, {n_shaded} shaded pixels{ss})")
            run.timings.update(r.timings)
        if REFERENCE in rs.methods:
            images[REFERENCE] = _reference(cfg, bundle, run)
        for method in rs.methods:
            img = images[method]
            art.write_image(run, method, img, exposure=rs.preview_exposure,
                            spp=rs.spp if method == REFERENCE else None)
            run.report.setdefault("mean_rgb", {})[method] = [
                round(float(c), 6) for c in img.reshape(-1, 3).mean(0)]
        run.report["shaded_pixels"] = n_shaded
        if rs.compare_to is not None:
            _compare(run, images, rs.compare_to, gb.object_id)
    return run


def supersample_offsets(n: int) -> list[tuple[float, float]]:
    """Sub-pixel positions (ox, oy) of `render.supersample` = n: the centres of an n×n grid of
    cells over the pixel (n = 1: the pixel centre), row by row. Their mean is a box filter."""
    c = [(k + 0.5) / n for k in range(n)]
    return [(ox, oy) for oy in c for ox in c]


def supersampled_frames(cam, tracer, bundle, n: int, background: bool, centre=None,
                        footprints: bool = False) -> list:
    """Per sub-pixel position of `supersample_offsets(n)`: (Frame of its G-buffer, background
    radiance or None). `centre`: the pixel-centre G-buffer when already traced."""
    from sgpipe.render.renderer import Frame
    from sgpipe.render.scene import ssdf_triangles
    from sgpipe.render.setup import latlong_lookup
    from sgpipe.scene.footprint import uv_derivatives
    out = []
    for off in supersample_offsets(n):
        o, d = cam.rays(offset=off)
        g = centre if centre is not None and off == (0.5, 0.5) else tracer.trace(o, d)
        vtri, vbary = ssdf_triangles(g, bundle.objects, bundle.proxies)
        bg = None
        if background and bundle.env_latlong is not None:
            bg = latlong_lookup(bundle.env_latlong, bundle.renderer.env.to_map(d))
        fr = Frame.from_gbuffer(g, vtri, vbary)
        if footprints:   # texture footprint of each sub-sample (1/n pixel): the MIP level
            fr.duv = uv_derivatives(cam, g, off, 1.0 / n).reshape(-1, 4)[fr.index]
        out.append((fr, bg))
    return out


def reference_from_config(cfg, *, objects=None, env=None):
    """The one config → `reference` path (sgpipe.reference.ReferenceResult): camera, pixel
    filter, scene objects with their normal maps and their materials' kd / ks textures,
    environment × 2^environment_exposure, materials, lights (delta, or spheres / discs of their
    radius with reference_area_lights), spp, seed, workers and background of a validated
    config. `objects` / `env` default to what the config names (meshes through
    their loader, the lat-long image); the stage passes its own (visibility geometry, the image
    it already read)."""
    from sgpipe.reference import render_reference_result
    from sgpipe.render.scene import load_trace_objects
    from sgpipe.render.setup import environment_latlong, material_brdf, object_material_specs
    from sgpipe.scene.camera import Camera
    rs = cfg.render
    specs = object_material_specs(cfg)
    brdfs = {}                         # one BRDF per material, shared by its objects
    for spec in specs:
        if spec.name not in brdfs:
            brdfs[spec.name] = material_brdf(spec)
    return render_reference_result(
        load_trace_objects(cfg) if objects is None else objects, Camera.from_spec(rs.camera),
        environment_latlong(cfg) if env is None else env,
        materials=[brdfs[s.name] for s in specs], lights=rs.lights,
        spp=rs.spp, seed=cfg.seed, workers=cfg.workers or None,
        background="env" if rs.background else "black",
        pixel_filter=to_plain(rs.pixel_filter), maps=object_maps(cfg),
        area_lights=rs.reference_area_lights, bounces=rs.reference_bounces,
        env_rotation=rs.environment_rotation.matrix(),
        mapped_backfacing=rs.reference_mapped_backfacing)


def object_maps(cfg) -> list:
    """Per scene object the images the OpenCL methods read for it (sgpipe.reference.ObjectMaps):
    its normal map, its material's kd / ks textures (render.material_textures), its textured
    glTF material and what it emits."""
    from sgpipe.reference import ObjectMaps
    from sgpipe.brdf import frame_rotation
    from sgpipe.render.setup import (emission_of, gltf_normal_texture, object_material_specs,
                                     read_texture)
    tex = {t.material: t for t in cfg.render.material_textures}
    cache: dict = {}
    assets: dict = {}           # glTF files, read once for all their primitives' objects

    def image(path, key):
        if path not in cache:
            cache[path] = read_texture(path, key)
        return cache[path]

    out = []
    specs = object_material_specs(cfg) if cfg.scene is not None else []
    for k, o in enumerate(cfg.scene.objects if cfg.scene is not None else []):
        t = tex.get(o.material)
        emission, etex = emission_of(cfg, specs[k], o, assets)
        out.append(ObjectMaps(
            normal_map=gltf_normal_texture(cfg, o, assets) if o.normal_map is None
            else image(o.normal_map, f"scene.objects.{k}.normal_map"),
            kd_map=image(t.kd_map, "render.material_textures.kd_map") if t and t.kd_map else None,
            ks_map=image(t.ks_map, "render.material_textures.ks_map") if t and t.ks_map else None,
            gltf=_gltf_surface(cfg, o, assets),
            emission=emission if emission.any() else None, emissive_texture=etex,
            frame_rotation=frame_rotation(specs[k])))
    return out


def _gltf_surface(cfg, obj, assets: dict):
    """The reference's view of an object's textured glTF material (sgpipe.reference's
    GltfSurface: the material's factors times its textures), or None (render.setup
    gltf_textures)."""
    from sgpipe.reference.surface import GltfSurface
    from sgpipe.render.setup import gltf_textures
    found = gltf_textures(cfg, obj, assets)
    if found is None:
        return None
    spec, base, mr, aniso = found
    p = spec.params
    return GltfSurface(np.broadcast_to(np.asarray(p.get("base_color", 1.0), float), (3,)),
                       float(p.get("metallic", 1.0)), float(p.get("roughness", 1.0)), base, mr,
                       float(p.get("anisotropy", 0.0)), aniso)


def _reference(cfg, bundle, run) -> np.ndarray:
    """The `reference` image (sgpipe.reference), its time and mean standard error."""
    rs = cfg.render
    t0 = time.perf_counter()
    res = reference_from_config(cfg, objects=bundle.objects, env=bundle.env_latlong)
    run.timings["reference_s"] = time.perf_counter() - t0
    run.report["reference_mean_stderr"] = float(np.mean(res.stderr))
    log(f"[render] reference: {rs.spp} spp in {run.timings['reference_s']:.1f} s")
    return res.image


def _compare(run, images: dict, truth: str, object_id: np.ndarray) -> None:
    """Metrics of every other method against `truth` via the compare stage's hook: display
    metrics at the preview exposure, surface variants from the G-buffer's object ids."""
    from sgpipe.metrics import surface_mask
    from sgpipe.stages.compare import compare_to_reference
    ref_path = run.path(art.image_name(truth))
    surface = surface_mask(object_id)
    for method, img in images.items():
        if method == truth:
            continue
        d = compare_to_reference(run, img, ref_path, method,
                                 exposure=run.cfg.render.preview_exposure, surface=surface)
        db = lambda v: "inf (identical)" if v is None else f"{v:.2f}"  # noqa: E731
        s = d["surface"]
        log(f"[render] {method} vs {truth}: display PSNR {db(d['display_psnr_db'])} dB "
            f"(surfaces {db(s['display_psnr_db'])} dB), LDR-FLIP {d['flip_ldr']:.4f} "
            f"(surfaces {s['flip_ldr']:.4f}), linear PSNR {db(d['psnr_db'])} dB, "
            f"SSIM {d['ssim']:.4f}")
