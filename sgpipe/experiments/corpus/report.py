"""The fidelity corpus's Markdown page: the worst cell per method, the goal line, the
method × scene matrix of surface display PSNR and the whole-frame / ꟻLIP / relMSE details."""

from __future__ import annotations

import math

from sgpipe.experiments.corpus.measure import noisy
from sgpipe.experiments.corpus.scenes import VISIBILITY

#: column order of the matrix
ORDER = ("sg", "gmm", "fis", "transport", "transport_green06", "vmf", "nm_sh", "normals_mip",
         "toksvig", "engine_bake")


def _methods(rows) -> list[str]:
    seen = {m for r in rows for m in (*r["methods"], *r["errors"])}
    return [m for m in ORDER if m in seen] + sorted(seen - set(ORDER))


def _material(mat: dict) -> str:
    p = mat["params"]
    if "alpha_u" in p:
        rough = f"α {p['alpha_u']:g} × {p['alpha_v']:g}"
    elif "alpha" in p:
        rough = f"α {p['alpha']:g}"
    else:
        rough = f"s {p['exponent']:g}"
    return f"{mat['model']} {rough}" + (" + diffuse" if "kd" in p else "")


def _cell(r: dict, m: str) -> str:
    v = r["methods"].get(m)
    if v is None:
        e = r["errors"].get(m)
        if e is None:
            return ""
        return "n/a" if e.startswith("BadInput") else "**failed**"
    star = "*" if noisy(v) else ""
    return f"{v['surface_display_psnr_db']:.1f}{star}"


#: the report `make figures` writes (the report seed); other seeds' reports name their own file
MAIN_RESULTS = "docs/results/fidelity.md"


def _scene(r: dict) -> str:
    return f"s{r['seed']} `{r['key']}`"


def markdown(rows: list[dict], meta: dict, misses: list[str]) -> str:
    ms = _methods(rows)
    seeds = ", ".join(str(s) for s in meta["seeds"])
    tuned = set(meta["seeds"]) & set(meta["tuning_seeds"])
    out = [
        "# Fidelity corpus",
        "",
        "Every method against the Monte Carlo `reference` (validated against Mitsuba 3, "
        "docs/VALIDATION.md) on the generated corpus of `sgpipe.experiments.corpus`: "
        f"{len(rows)} scenes, seed{'s' if len(meta['seeds']) > 1 else ''} {seeds} "
        + ("(**a tuning seed**)" if tuned else
           f"(not a seed any method was tuned on; tuning seeds: "
           f"{', '.join(str(s) for s in meta['tuning_seeds'])})")
        + f", {meta['size']}² pixels, the real-time methods 3×3 supersampled, the reference "
        f"box-filtered at 2 × {meta['spp']} spp (two seeds, averaged); shadows from "
        f"{VISIBILITY['trace_resolution']}² rays per vertex into {VISIBILITY['resolution']}² "
        f"SSDFs of {VISIBILITY['pca_terms']} PCA terms. Numbers are display "
        "PSNR in dB (the 8-bit preview: clamp at the preview exposure, sRGB) over the surface "
        "pixels, corrected for the reference's noise; `*` marks a cell within 3 dB of that "
        "noise, where the value is a lower bound. Each scene's preview exposure (≤ 0, in half "
        "stops) puts the 90th percentile of a 16-spp reference's surface pixels at 1. `n/a`: "
        "the method refuses the scene's material (its paper has no closed form for it). The "
        "last table gives the exposure and the share of surface pixels the preview still "
        "clamps, where display PSNR sees no error.",
        "",
        "Regenerate: `python -m sgpipe.experiments.fidelity --out out/figures/fidelity "
        f"--seed {seeds} --results {meta.get('results', MAIN_RESULTS)}` ("
        + ("part of `make figures`; " if meta.get("results", MAIN_RESULTS) == MAIN_RESULTS
           else "")
        + f"{meta['seconds'] / 60:.0f} min on 2 cores).",
        "",
        "## Worst cell per method",
        "",
        "| method | worst scene | surface dB | frame dB | LDR-ꟻLIP (surface) | relMSE (surface) "
        "| median surface dB | scenes |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for m in ms:
        cells = [(r, r["methods"][m]) for r in rows if m in r["methods"]]
        if not cells:
            continue
        r, v = min(cells, key=lambda c: c[1]["surface_display_psnr_db"])
        vals = sorted(c[1]["surface_display_psnr_db"] for c in cells)
        med = vals[len(vals) // 2] if len(vals) % 2 else 0.5 * (vals[len(vals) // 2 - 1]
                                                                 + vals[len(vals) // 2])
        out.append(f"| {m} | {_scene(r)} | {v['surface_display_psnr_db']:.1f} | "
                   f"{v['display_psnr_db']:.1f} | {v['surface_flip_ldr']:.3f} | "
                   f"{v['surface_rel_mse']:.2e} | {med:.1f} | {len(cells)} |")
    out += ["", f"**Goal**: `sg` and `gmm` ≥ {meta['goal_db']:.0f} dB surface "
            "display PSNR on every scene without a normal map: "
            + ("**met**." if not misses else f"**not met** on {len(misses)} cell"
               f"{'s' if len(misses) > 1 else ''}: " + "; ".join(misses) + "."), ""]
    out += ["## Surface display PSNR, method × scene", "",
            "| scene | material | " + " | ".join(ms) + " |",
            "|---|---|" + "---|" * len(ms)]
    for r in rows:
        out.append(f"| {_scene(r)} | {_material(r['material'])} | "
                   + " | ".join(_cell(r, m) for m in ms) + " |")
    out += ["", "## Whole frame, ꟻLIP, relMSE and cost", "",
            "Per scene and method: whole-frame display PSNR (noise-corrected), surface "
            "LDR-ꟻLIP, surface linear relMSE and the frame time (ms, 3×3 supersampled, this "
            "machine).", "",
            "| scene | preview exposure / reference noise (seed A vs B, surface dB) / clipped | "
            "method | frame dB | ꟻLIP | relMSE | ms |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        for k, (m, v) in enumerate(sorted(r["methods"].items(), key=lambda x: ORDER.index(x[0])
                                          if x[0] in ORDER else 99)):
            head = (f"{_scene(r)} | {r['exposure']:+g} / {r['seed_surface_psnr_db']:.1f} / "
                    f"{100 * r['clipped']:.0f} %" if k == 0 else " | ")
            ms_v = "" if not math.isfinite(v["ms"]) else f"{v['ms']:.0f}"
            out.append(f"| {head} | {m} | {v['display_psnr_db']:.1f} | "
                       f"{v['surface_flip_ldr']:.3f} | {v['surface_rel_mse']:.2e} | {ms_v} |")
        for m, e in r["errors"].items():
            out.append(f"| {_scene(r)} | | {m} | {e} | | | |")
    return "\n".join(out) + "\n"
