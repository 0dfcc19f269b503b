"""One validation scene: the sgpipe reference and Mitsuba 3 renders of the same config, and
their comparison in sgpipe.metrics' display terms (whole frame and surface pixels)."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SCENES_DIR = Path(__file__).resolve().parent / "scenes"
MIN_DISPLAY_PSNR_DB = 40.0
#: a scene below 40 dB still passes within this many dB of the joint noise floor (joint_floor_db)
NOISE_FLOOR_MARGIN_DB = 2.0


def scene_paths(names=None) -> list[Path]:
    """The stored scene configs (validation/scenes/*.yaml), all or those named."""
    paths = sorted(SCENES_DIR.glob("*.yaml"))
    if names:
        by_name = {p.stem: p for p in paths}
        missing = [n for n in names if n not in by_name]
        if missing:
            raise KeyError(f"unknown scene(s) {missing}; known: {sorted(by_name)}")
        paths = [by_name[n] for n in names]
    return paths


def sgpipe_has_pixel_filter() -> bool:
    """Whether sgpipe's reference integrates over the pixel (a `render.pixel_filter` key)."""
    from sgpipe.config.sections.render import RenderSection
    return any(f.name == "pixel_filter" for f in dataclasses.fields(RenderSection))


def _set_pixel_filter(cfg, kind: str):
    """cfg.render.pixel_filter set to `kind` (box | center), whatever form the key takes."""
    rs = cfg.render
    cur = rs.pixel_filter
    if cur is None or isinstance(cur, str):
        rs.pixel_filter = kind
    elif dataclasses.is_dataclass(cur):
        rs.pixel_filter = dataclasses.replace(cur, type=kind)
    elif isinstance(cur, dict):
        rs.pixel_filter = dict(cur, type=kind)
    else:
        raise TypeError(f"cannot set render.pixel_filter of type {type(cur).__name__}")


@dataclass
class SceneResult:
    name: str
    mode: str                      # "filter" (the config's pixel filter) or "centre"
    width: int
    height: int
    spp_sgpipe: int
    spp_mitsuba: int
    metrics: dict                  # sgpipe.metrics.compare_images of sgpipe vs Mitsuba
    noise_floor_db: float          # display PSNR of Mitsuba seed A vs seed B (whole frame)
    noise_floor_surface_db: float
    sgpipe_s: float
    mitsuba_s: float
    mean_ratio: float              # Σ luminance sgpipe / Σ luminance Mitsuba − 1, surfaces
    mean_ratio_sigma: float        # its standard error (both renderers' sample noise)
    joint_floor_db: float = float("inf")   # display PSNR two unbiased renders would reach
    images: dict = field(default_factory=dict, repr=False)   # sgpipe, mitsuba, surface


def load_scene_config(path: Path, overrides=()):
    from sgpipe.config.loader import load_config
    from validation.assets import ensure_for_scene
    ensure_for_scene(path)             # generated inputs (../generated/…) before validation
    return load_config(path, list(overrides))


def render_sgpipe(cfg, mode: str):
    """sgpipe's reference of the config (the one config → reference path): with the config's
    pixel filter (mode "filter") or through pixel centres only (mode "centre")."""
    from sgpipe.stages.render import reference_from_config
    if not sgpipe_has_pixel_filter():
        if mode == "filter":
            raise RuntimeError("sgpipe's reference has no pixel filter: use mode centre")
    elif mode == "centre":
        _set_pixel_filter(cfg, "center")
    return reference_from_config(cfg)


def surface_of(cfg) -> np.ndarray:
    """Surface pixels (sgpipe.metrics.surface_mask) of the pixel-centre G-buffer."""
    from sgpipe.metrics import surface_mask
    from sgpipe.render.scene import load_trace_objects
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import Tracer
    cam = Camera.from_spec(cfg.render.camera)
    gb = Tracer(load_trace_objects(cfg)).trace(*cam.rays())
    return surface_mask(gb.object_id)


def mean_ratio(img, mi_a, mi_b, stderr, mask) -> tuple[float, float]:
    """(Σ Y_sgpipe / Σ Y_Mitsuba − 1, its standard error) over the mask, Y = luminance: an
    energy check far finer than PSNR. The error combines sgpipe's per-pixel standard error
    and Mitsuba's from its two independent halves (var of their mean ≈ (a − b)²/4)."""
    from sgpipe.metrics import luminance
    m = np.asarray(mask, bool)
    ys, ya, yb = (luminance(x)[m] for x in (img, mi_a, mi_b))
    ym = 0.5 * (ya + yb)
    var = (luminance(np.asarray(stderr, np.float64) ** 2) if stderr is not None else 0.0)
    var_s = var[m] if np.ndim(var) else np.zeros_like(ys)
    tot = float(ym.sum())
    if tot <= 0:
        return 0.0, 0.0
    se = float(np.sqrt(np.sum(var_s + 0.25 * (ya - yb) ** 2))) / tot
    return float(ys.sum() / tot - 1.0), se


def display_slope(img, exposure: float) -> np.ndarray:
    """d(8-bit display value)/d(radiance) of tonemap_srgb (unrounded), per pixel and channel:
    0 where the preview clamps."""
    k = 2.0 ** exposure
    y = np.asarray(img, np.float64)[..., :3] * k
    lin = y <= 0.0031308
    srgb = 1.055 / 2.4 * np.power(np.maximum(y, 0.0031308), 1.0 / 2.4 - 1.0)
    return 255.0 * k * np.where((y <= 0) | (y >= 1), 0.0, np.where(lin, 12.92, srgb))


def joint_noise_floor(img, stderr, mi_a, mi_b, exposure: float) -> float:
    """Display PSNR between sgpipe's image and Mitsuba's mean if both were unbiased: display
    MSE = sgpipe's sample noise (its per-pixel standard error through the preview's slope) +
    Mitsuba's (its halves' display MSE / 4: the mean of two halves has a quarter of their
    difference's variance)."""
    from sgpipe.metrics import display_image
    da, db = (display_image(x, exposure=exposure).astype(np.float64) for x in (mi_a, mi_b))
    mse_mi = float(np.mean((da - db) ** 2)) / 4.0
    mse_sg = 0.0 if stderr is None else float(np.mean(
        (display_slope(img, exposure) * np.asarray(stderr, np.float64)[..., :3]) ** 2))
    mse = mse_mi + mse_sg
    return float("inf") if mse <= 0 else float(10.0 * np.log10(255.0 ** 2 / mse))


def run_scene(path: Path, *, mode: str, spp_sgpipe: int | None = None, spp_mitsuba: int = 4096,
              size: int | None = None, env_factor=None, log=print) -> SceneResult:
    """Render one scene config with both renderers and compare (module docstring)."""
    from sgpipe.metrics import compare_images, display_psnr
    from validation import mitsuba_scene as ms
    over = []
    if spp_sgpipe:
        over.append(f"render.spp={int(spp_sgpipe)}")
    if size:
        over += [f"render.camera.width={int(size)}", f"render.camera.height={int(size)}"]
    cfg = load_scene_config(path, over)
    rs = cfg.render
    t0 = time.perf_counter()
    ref = render_sgpipe(cfg, mode)
    t_sg = time.perf_counter() - t0
    t0 = time.perf_counter()
    scene = ms.load_scene(cfg, env_factor=env_factor or ms.ENV_FACTOR, centre=mode == "centre")
    half = max(1, spp_mitsuba // 2)
    render = ms.render_filter if mode == "filter" else ms.render_centre
    mi_a = render(scene, half, seed=1)
    mi_b = render(scene, half, seed=2)
    t_mi = time.perf_counter() - t0
    mitsuba = 0.5 * (mi_a + mi_b)
    surface = surface_of(cfg)
    img = np.asarray(ref.image, np.float64)
    metrics = compare_images(img, mitsuba, exposure=rs.preview_exposure, surface=surface)
    floor = display_psnr(mi_a, mi_b, exposure=rs.preview_exposure)
    floor_s = display_psnr(mi_a, mi_b, exposure=rs.preview_exposure, mask=surface)
    stderr = getattr(ref, "stderr", None)
    ratio, ratio_se = mean_ratio(img, mi_a, mi_b, stderr, surface)
    joint = joint_noise_floor(img, stderr, mi_a, mi_b, rs.preview_exposure)
    log(f"[validate] {cfg.name}: display PSNR {metrics['display_psnr_db']:.2f} dB "
        f"(surfaces {metrics['surface']['display_psnr_db']:.2f} dB), LDR-FLIP "
        f"{metrics['flip_ldr']:.4f}, Mitsuba noise floor {floor:.2f} dB, joint noise floor "
        f"{joint:.2f} dB, surface mean "
        f"{100 * ratio:+.3f} ± {100 * ratio_se:.3f} %; sgpipe {t_sg:.1f} s, "
        f"Mitsuba {t_mi:.1f} s")
    return SceneResult(name=cfg.name, mode=mode, width=rs.camera.width, height=rs.camera.height,
                       spp_sgpipe=rs.spp, spp_mitsuba=2 * half, metrics=metrics,
                       noise_floor_db=floor, noise_floor_surface_db=floor_s, sgpipe_s=t_sg,
                       mitsuba_s=t_mi, mean_ratio=ratio, mean_ratio_sigma=ratio_se,
                       joint_floor_db=joint,
                       images={"sgpipe": img, "mitsuba": mitsuba, "surface": surface,
                               "exposure": rs.preview_exposure})
