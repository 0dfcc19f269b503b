"""The validation report: per-scene images (EXR + PNG, side by side with a false-colour
difference), the table as JSON and Markdown, and the console table."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from validation.run import MIN_DISPLAY_PSNR_DB, NOISE_FLOOR_MARGIN_DB, SceneResult

COLUMNS = ("scene", "mode", "size", "spp sgpipe / Mitsuba", "display PSNR (dB)",
           "surfaces (dB)", "LDR-ꟻLIP", "relMSE", "Mitsuba noise floor (dB)",
           "joint noise floor (dB)", "surface mean Δ (%)", "sgpipe (s)", "Mitsuba (s)")


def _db(v) -> str:
    return "inf" if v is None or (isinstance(v, float) and math.isinf(v)) else f"{v:.2f}"


def _json_num(v):
    return None if isinstance(v, float) and not math.isfinite(v) else v


def row(r: SceneResult) -> dict:
    m, s = r.metrics, r.metrics["surface"]
    return {"scene": r.name, "mode": r.mode, "width": r.width, "height": r.height,
            "spp_sgpipe": r.spp_sgpipe, "spp_mitsuba": r.spp_mitsuba,
            "display_psnr_db": _json_num(m["display_psnr_db"]),
            "surface_display_psnr_db": _json_num(s["display_psnr_db"]),
            "flip_ldr": m["flip_ldr"], "surface_flip_ldr": s["flip_ldr"],
            "flip_hdr": m["flip_hdr"], "rel_mse": m["rel_mse"], "surface_rel_mse": s["rel_mse"],
            "surface_pixels": s["pixels"],
            "noise_floor_db": _json_num(r.noise_floor_db),
            "noise_floor_surface_db": _json_num(r.noise_floor_surface_db),
            "joint_noise_floor_db": _json_num(r.joint_floor_db),
            "surface_mean_ratio_minus_1": r.mean_ratio,
            "surface_mean_ratio_sigma": r.mean_ratio_sigma,
            "sgpipe_s": round(r.sgpipe_s, 2), "mitsuba_s": round(r.mitsuba_s, 2),
            "pass": passes(r)}


def passes(r: SceneResult) -> bool:
    """Whole-frame display PSNR ≥ 40 dB, or within 2 dB of the joint noise floor (what two
    unbiased renders at these sample counts would reach)."""
    db = r.metrics["display_psnr_db"]
    return bool(db >= MIN_DISPLAY_PSNR_DB or db >= r.joint_floor_db - NOISE_FLOOR_MARGIN_DB)


def table_lines(results: list[SceneResult]) -> list[str]:
    """Markdown table lines (also what the console prints)."""
    out = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in results:
        m, s = r.metrics, r.metrics["surface"]
        cells = [r.name, r.mode, f"{r.width}×{r.height}", f"{r.spp_sgpipe} / {r.spp_mitsuba}",
                 _db(m["display_psnr_db"]) + ("" if passes(r) else " ✗"),
                 _db(s["display_psnr_db"]), f"{m['flip_ldr']:.4f}", f"{m['rel_mse']:.2e}",
                 _db(r.noise_floor_db), _db(r.joint_floor_db),
                 f"{100 * r.mean_ratio:+.2f} ± {100 * r.mean_ratio_sigma:.2f}",
                 f"{r.sgpipe_s:.1f}", f"{r.mitsuba_s:.1f}"]
        out.append("| " + " | ".join(cells) + " |")
    return out


def write_images(folder: Path, r: SceneResult) -> None:
    """<scene>.sgpipe.exr/.png, <scene>.mitsuba.exr/.png, <scene>.diff.png (false colour,
    signed luminance difference) and <scene>.side.png (sgpipe | Mitsuba | diff)."""
    from sgpipe.io import write_exr
    from sgpipe.io.png import tonemap_srgb, write_png
    from sgpipe.metrics import false_color_difference
    folder.mkdir(parents=True, exist_ok=True)
    im, exp = r.images, r.images["exposure"]
    for key in ("sgpipe", "mitsuba"):
        write_exr(folder / f"{r.name}.{key}.exr", im[key])
        write_png(folder / f"{r.name}.{key}.png", im[key], exposure=exp)
    diff = false_color_difference(im["sgpipe"], im["mitsuba"])
    write_png(folder / f"{r.name}.diff.png", diff, already_8bit=True)
    gap = np.full((im["sgpipe"].shape[0], 4, 3), 255, np.uint8)
    side = np.concatenate([tonemap_srgb(im["sgpipe"], exposure=exp), gap,
                           tonemap_srgb(im["mitsuba"], exposure=exp), gap, diff], 1)
    write_png(folder / f"{r.name}.side.png", side, already_8bit=True)


def write_report(folder: Path, results: list[SceneResult], *, notes: list[str]) -> None:
    """table.json and table.md in `folder`."""
    folder.mkdir(parents=True, exist_ok=True)
    data = {"min_display_psnr_db": MIN_DISPLAY_PSNR_DB, "notes": notes,
            "scenes": [row(r) for r in results]}
    (folder / "table.json").write_text(json.dumps(data, indent=2, ensure_ascii=False) + "\n")
    md = ["# sgpipe reference vs Mitsuba 3", "",
          "Display PSNR and ꟻLIP of the 8-bit previews (sgpipe.metrics), sgpipe's reference "
          "as the image and Mitsuba as the reference; surfaces: pixels whose 3×3 "
          "neighbourhood is one object; surface mean Δ: Σ luminance sgpipe / Σ Mitsuba − 1 over "
          "the surface pixels ± its standard error (an energy check finer than PSNR); joint noise "
          "floor: the display PSNR two unbiased renders at these sample counts would reach (a "
          "scene passes at ≥ 40 dB or within 2 dB of it). Images: `<scene>.side.png` = "
          "sgpipe | Mitsuba | signed luminance difference.", ""] + [f"- {n}" for n in notes] + [""]
    (folder / "table.md").write_text("\n".join(md + table_lines(results)) + "\n")
