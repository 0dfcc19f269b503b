"""The fidelity corpus's normal-mapped scenes as a section of docs/results/han07.md: environment
lighting (a sky with a sun, hard-edged lamps, smooth studio maps), grazing views and v-grooves
beside Fig 2's head-on subjects, with the targets of the Han07 fidelity issue: at 16× and 64×
the best Han07 method ≥ TARGET_DB and ≥ MARGIN_DB over the best unfiltered method (sg, gmm,
fis shade the full-resolution map); at 1× every Han07 method within ONE_X_DB of the reference's
agreement with itself (seed A against seed B)."""

from __future__ import annotations

import json
import re
from pathlib import Path

HAN07 = ("vmf", "nm_sh", "normals_mip", "toksvig", "engine_bake")
UNFILTERED = ("sg", "gmm", "fis")
TARGET_DB, MARGIN_DB, ONE_X_DB = 30.0, 6.0, 1.0


def minification(key: str) -> int | None:
    """Texels per pixel of a corpus slot key (`…-grooves16x-…` → 16)."""
    m = re.search(r"(\d+)x(?:-|$)", key)
    return int(m.group(1)) if m else None


def _best(row: dict, methods) -> tuple[str, float] | None:
    cells = [(m, row["methods"][m]["surface_display_psnr_db"]) for m in methods
             if m in row["methods"]]
    return max(cells, key=lambda c: c[1]) if cells else None


def verdict(row: dict) -> tuple[bool | None, str]:
    """(met, why) of one normal-mapped row against the issue's targets; met None at 4×."""
    k = minification(row["key"])
    han, unf = _best(row, HAN07), _best(row, UNFILTERED)
    if han is None or unf is None:
        return False, "a method failed"
    if k in (16, 64):
        gap = han[1] - unf[1]
        ok = han[1] >= TARGET_DB and gap >= MARGIN_DB
        return ok, f"{han[0]} {han[1]:.1f} dB, {gap:+.1f} dB over {unf[0]}"
    if k == 1:
        agree = row["seed_surface_psnr_db"]
        worst = min(((m, row["methods"][m]["surface_display_psnr_db"]) for m in HAN07
                     if m in row["methods"]), key=lambda c: c[1])
        return worst[1] >= agree - ONE_X_DB, (f"worst {worst[0]} {worst[1]:.1f} dB, "
                                             f"reference seeds agree to {agree:.1f} dB")
    return None, "no target at this minification"


def corpus_section(path: Path) -> list[str]:
    """Markdown lines of the section from a fidelity corpus JSON (`python -m
    sgpipe.experiments.fidelity`, written beside its report), or a line saying it is absent."""
    L = ["## Environment-lit and grazing subjects (fidelity corpus)", ""]
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return L + [f"Not available: {path} is written by the fidelity corpus "
                    "(`python -m sgpipe.experiments.fidelity`).", ""]
    meta = data["meta"]
    rows = [r for r in data["rows"] if r.get("normal_map")]
    tuned = sorted(set(meta["seeds"]) & set(meta["tuning_seeds"]))
    L += [f"The normal-mapped scenes of the fidelity corpus (docs/results/{Path(path).stem}.md, "
          f"seed{'s' if len(meta['seeds']) > 1 else ''} "
          f"{', '.join(str(s) for s in meta['seeds'])}"
          + (f"; **tuning seed{'s' if len(tuned) > 1 else ''}** "
             f"{', '.join(str(s) for s in tuned)}" if tuned else
             f"; not a tuning seed — those are {', '.join(str(s) for s in meta['tuning_seeds'])}")
          + f"; {meta['size']}², methods 3×3 supersampled, reference 2 × {meta['spp']} spp): "
          "generated maps (grooves along and across the view, v-grooves, bumps) on a plane "
          "head-on or at 10–20° grazing and on a UV sphere, minified 1–64×, under a sky with a "
          "sun, hard-edged lamps, a mixed map or data_samples' studio map, some with a "
          "directional light. Cells: surface display PSNR (dB) corrected for the reference's "
          "noise. Targets: at 16× and 64× the best Han07 method ≥ "
          f"{TARGET_DB:.0f} dB and ≥ {MARGIN_DB:.0f} dB over the best unfiltered method "
          f"({', '.join(UNFILTERED)}); at 1× every Han07 method within {ONE_X_DB:.0f} dB of the "
          "reference's seed-against-seed agreement.", "",
          "| scene | " + " | ".join(HAN07) + " | " + " | ".join(UNFILTERED)
          + " | target | |", "|---|" + "---|" * (len(HAN07) + len(UNFILTERED) + 2)]
    for r in rows:
        cells = [f"{r['methods'][m]['surface_display_psnr_db']:.1f}" if m in r["methods"]
                 else "failed" if m in r.get("errors", {}) else "" for m in HAN07 + UNFILTERED]
        ok, why = verdict(r)
        mark = "—" if ok is None else ("met" if ok else "**not met**")
        L.append(f"| s{r['seed']} `{r['key']}` | " + " | ".join(cells) + f" | {mark} | {why} |")
    return L + [""]
