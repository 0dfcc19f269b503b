"""The render stage: `cfg.render` → `<out>/render/` (docs/ARTIFACTS.md render/).

Primary visibility once (Embree G-buffer), then every method of `render.methods`: `sg`, `gmm`,
`fis` shade the G-buffer with OpenCL kernels; `reference` is the Monte Carlo ground truth of
`sgpipe.render.reference`. Each image is written as linear EXR + PNG preview; timings go to
timings.json (wall clock), image statistics and comparisons to the manifest report.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sgpipe.config.schema import to_plain
from sgpipe.errors import BadInput
from sgpipe.stages.base import StageRun, log

SHADERS = ("sg", "gmm", "fis")


def _inputs(cfg, out_dir: Path) -> list[Path]:
    """Upstream manifests (they hash every artifact) and the files the scene names."""
    files = [out_dir / s / "manifest.json" for s in ("fit", "envmap", "visibility")
             if getattr(cfg, s, None) is not None]
    for o in cfg.scene.objects if cfg.scene is not None else []:
        files += [Path(p) for p in (o.mesh, o.normal_map) if p]
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
    from sgpipe.render.camera import Camera
    from sgpipe.render.gbuffer import Tracer
    from sgpipe.render.renderer import Frame
    from sgpipe.render.setup import build_scene, latlong_lookup, reference_lights

    out_dir = Path(out_dir)
    rs = cfg.render
    for stage, cmd in (("fit", "fit"), ("envmap", "precompute"), ("visibility", "precompute")):
        done = (out_dir / stage / "manifest.json").is_file()
        if getattr(cfg, stage, None) is not None and not done:
            raise BadInput(f"no {stage} artifacts here: run `sgpipe {cmd}` (or `sgpipe run`) "
                           f"with the same --out first", file=out_dir / stage, key=stage)
    params = {"render": to_plain(rs), "scene": to_plain(cfg.scene),
              "materials": to_plain(cfg.fit.materials) if cfg.fit is not None else []}
    with StageRun(cfg, out_dir, "render", params=params, inputs=_inputs(cfg, out_dir),
                  force=force) as run:
        if run.skipped:
            return run
        shaders = [m for m in rs.methods if m in SHADERS]
        t0 = time.perf_counter()
        bundle = build_scene(cfg, out_dir, rs.methods)
        run.timings["setup_s"] = time.perf_counter() - t0
        cam = Camera.from_spec(rs.camera)
        origins, dirs = cam.rays()
        t0 = time.perf_counter()
        tracer = Tracer(bundle.objects)
        gb = tracer.trace(origins, dirs)
        from sgpipe.render.scene import ssdf_triangles
        vtri, vbary = ssdf_triangles(gb, bundle.objects, bundle.proxies)
        frame = Frame.from_gbuffer(gb, vtri, vbary)
        run.timings["gbuffer_s"] = time.perf_counter() - t0
        bg = None
        if rs.background and bundle.env_latlong is not None:
            bg = latlong_lookup(bundle.env_latlong, dirs)
        run.write_npz("gbuffer.npz", {
            "hit": gb.hit, "position": gb.position, "normal": gb.normal,
            "tangent": gb.tangent, "uv": gb.uv, "object_id": gb.object_id,
            "triangle_id": gb.triangle_id, "barycentrics": gb.barycentrics})
        r = bundle.renderer
        images = {}
        if shaders:
            fdev = r.upload_frame(frame)
            mip_cov = float(getattr(cfg.envmap, "mip_coverage", 0.9) or 0.9)
            for method in shaders:
                rgb, sec = _time_method(
                    r, method, fdev, rs.timing_repeats, fis_samples=rs.fis_samples,
                    gmm_interpolate=rs.gmm_interpolate, mip_coverage=mip_cov,
                    flags=0 if (method == "sg" or rs.baseline_shadows) else 4)
                images[method] = frame.to_image(rgb, bg)
                run.timings[f"{method}_s"] = sec
                run.timings[f"{method}_fps"] = 1.0 / sec if sec > 0 else float("inf")
                log(f"[render] {method}: {sec * 1e3:.1f} ms/frame "
                    f"({cam.width}x{cam.height}, {len(frame.index)} shaded pixels)")
            run.timings.update({k: v for k, v in r.timings.items()})
        if "reference" in rs.methods:
            images["reference"] = _reference(cfg, bundle, cam, run)
        for method in rs.methods:
            img = images[method]
            run.write_exr(f"{method}.exr", img, exposure=rs.preview_exposure,
                          metadata={"method": method,
                                    **({"spp": rs.spp} if method == "reference" else {})})
            run.report.setdefault("mean_rgb", {})[method] = [
                round(float(c), 6) for c in img.reshape(-1, 3).mean(0)]
        run.report["shaded_pixels"] = int(len(frame.index))
        if rs.compare_to is not None:
            _compare(run, images, rs.compare_to)
    return run


def _reference(cfg, bundle, cam, run) -> np.ndarray:
    """The other render developer's Monte Carlo reference (sgpipe.render.reference)."""
    from sgpipe.render import reference as ref
    from sgpipe.render.setup import reference_lights
    rs = cfg.render
    t0 = time.perf_counter()
    res = ref.render_reference_result(
        bundle.objects, cam, bundle.env_latlong, materials=ref.materials_for_scene(cfg),
        lights=reference_lights(rs), spp=rs.spp, seed=cfg.seed, workers=cfg.workers or None,
        background="env" if rs.background else "black")
    run.timings["reference_s"] = time.perf_counter() - t0
    run.report["reference_mean_stderr"] = float(np.mean(res.stderr))
    log(f"[render] reference: {rs.spp} spp in {run.timings['reference_s']:.1f} s")
    return res.image


def _compare(run, images: dict, truth: str) -> None:
    """Metrics of every other method against `truth` via the compare stage's hook."""
    from sgpipe.stages import compare as cmp
    ref_path = run.path(f"{truth}.exr")
    for method, img in images.items():
        if method == truth:
            continue
        if hasattr(cmp, "compare_to_reference"):
            d = cmp.compare_to_reference(run, img, ref_path, method)
            psnr = d.get("psnr_db")
            shown = "inf (identical)" if psnr is None else f"{psnr:.2f}"
            log(f"[render] {method} vs {truth}: PSNR {shown} dB, SSIM {d.get('ssim', 0):.4f}")
        else:  # pragma: no cover - compare stage absent
            err = float(np.mean((img - images[truth]) ** 2))
            run.report.setdefault("compare", {})[method] = {"mse": err}
