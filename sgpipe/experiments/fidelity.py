"""The fidelity corpus: every method against the validated `reference` on generated
scenes that no method was tuned on.

    python -m sgpipe.experiments.fidelity --out out/figures/fidelity [--seed N ...]
        [--scenes KEY ...] [--size 96] [--spp 256] [--quick] [--results FILE]

The corpus (sgpipe.experiments.corpus.scenes) crosses shapes (sphere, teapot, a thick bowl, a
plane head-on and at 10–20° grazing, a UV sphere), maps (hard-edged lamps, sky + sun, a mixed
map generated per scene, data_samples' studio and sky_sun), materials (Beckmann / GGX / Ward,
α 0.02–0.4, anisotropic up to 20:1, with and without a diffuse layer), normal maps (none,
grooves, bumps, v-grooves, minified 1–64×) and lights; a seed draws each slot's parameters.
Each scene runs through the real stages (fit → precompute → render, 3×3 supersampled) and is
compared with a two-seed reference (box pixel filter): surface and whole-frame display PSNR
corrected for the reference's noise, LDR-ꟻLIP and linear relMSE. Writes <out>/fidelity.json,
the images (EXR + PNG) under <out>/scenes/<seed>/<key>/, and the Markdown matrix (`--results`,
default <out>/fidelity.md) with the worst cell per method on top and its numbers beside it
(the same name, .json; docs/results/han07.md reads the report seed's). `--update --scenes …`
re-measures those slots only and rewrites the report from all rows.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from sgpipe.experiments.corpus import report
from sgpipe.experiments.corpus.scenes import SLOTS, scenes

#: the seed the corpus is reported on; TUNING_SEEDS are those method changes were tried on
#: or motivated by (docs/results/fidelity_seed7.md keeps seed 7's matrix, marked as such)
REPORT_SEED = 11
TUNING_SEEDS = (1, 7)
GOAL_DB = 35.0
GOAL_METHODS = ("sg", "gmm")


def _row(scene: dict, r: dict) -> dict:
    """The JSON-able numbers of one measured scene."""
    keep = ("surface_display_psnr_db", "display_psnr_db", "raw_surface_display_psnr_db",
            "surface_floor_db", "floor_db", "surface_flip_ldr", "flip_ldr", "surface_rel_mse",
            "rel_mse", "ms")
    ref = r["reference"]
    return {"key": scene["key"], "seed": scene["config"]["seed"],
            "exposure": ref["exposure"],
            "material": scene["material"], "methods_asked": scene["methods"],
            "normal_map": scene["slot"].normal_map, "env": scene["slot"].env,
            "shape": scene["slot"].shape, "reference_spp": ref["spp"],
            "reference_seconds": ref["seconds"],
            "seed_surface_psnr_db": ref["seed_surface_psnr_db"],
            "clipped": clipped_fraction(ref),
            "methods": {m: {k: float(v[k]) for k in keep} for m, v in r["methods"].items()},
            "errors": r["errors"]}


#: samples per pixel of the quick reference that sets a scene's preview exposure
EXPOSURE_SPP = 16
#: ... and the percentile of its surface pixels (brightest channel) that the preview puts at 1
PERCENTILE = 90.0


def preview_exposure(config: dict) -> float:
    """The scene's preview exposure in half stops, never above 0: the darkening that puts the
    PERCENTILE-th percentile of a quick reference's surface pixels (brightest channel) at 1, so
    that a surface lit brighter than white is measured instead of clamped."""
    import dataclasses

    import numpy as np

    from sgpipe.experiments.corpus.measure import load_scene, surface_of
    from sgpipe.stages.render import reference_from_config
    cfg = load_scene(config)
    cfg = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, spp=EXPOSURE_SPP))
    img = np.asarray(reference_from_config(cfg).image)[..., :3].max(axis=-1)
    mask = surface_of(cfg)
    level = float(np.percentile(img[mask], PERCENTILE)) if mask.any() else 0.0
    return 0.0 if level <= 1.0 else -math.ceil(2.0 * math.log2(level)) / 2.0


def clipped_fraction(ref: dict) -> float:
    """Fraction of the reference's surface pixels that the preview clamps (a channel ≥ 1 at the
    preview exposure): display PSNR cannot see errors there."""
    import numpy as np
    img = np.asarray(ref["image"])[..., :3] * 2.0 ** ref["exposure"]
    mask = np.asarray(ref["surface"], bool)
    return float((img[mask].max(axis=-1) >= 1.0).mean()) if mask.any() else 0.0


def _save_images(folder: Path, r: dict, exposure: float) -> None:
    from sgpipe.io.exr import write_exr
    from sgpipe.io.png import write_png
    folder.mkdir(parents=True, exist_ok=True)
    for name, img in [("reference", r["reference"]["image"]),
                      *((m, v["image"]) for m, v in r["methods"].items())]:
        write_exr(folder / f"{name}.exr", img)
        write_png(folder / f"{name}.png", img, exposure=exposure)


def run_corpus(out: Path, seeds, *, size: int, spp: int, only=None, log=print) -> list[dict]:
    """Measure every scene of every seed; rows in corpus order."""
    from sgpipe.experiments.corpus.measure import measure
    rows = []
    todo = [(seed, s) for seed in seeds for s in scenes(seed, out / "inputs", size=size,
                                                         spp=spp, only=only)]
    t0 = time.perf_counter()
    for k, (seed, s) in enumerate(todo):
        t = time.perf_counter()
        work = out / "work" / f"s{seed}" / s["key"]
        s["config"]["render"]["preview_exposure"] = preview_exposure(s["config"])
        r = measure(s["config"], s["methods"], spp=spp, out=work, quiet=True)
        _save_images(out / "scenes" / f"s{seed}" / s["key"], r, r["reference"]["exposure"])
        rows.append(_row(s, r))
        cells = " ".join(f"{m} {v['surface_display_psnr_db']:.1f}"
                         for m, v in r["methods"].items())
        fails = " ".join(f"{m} FAILED" for m in r["errors"])
        done = time.perf_counter() - t0
        eta = done / (k + 1) * (len(todo) - k - 1)
        log(f"[{k + 1}/{len(todo)}] s{seed} {s['key']}: {cells} {fails} "
            f"({time.perf_counter() - t:.0f} s; ETA {eta / 60:.1f} min)")
    return rows


def goal_misses(rows: list[dict]) -> list[str]:
    """sg / gmm below GOAL_DB (surface) on a scene without a normal map."""
    out = []
    for r in rows:
        if r["normal_map"]:
            continue
        for m in GOAL_METHODS:
            v = r["methods"].get(m)
            if v is None or not v["surface_display_psnr_db"] >= GOAL_DB:
                out.append(f"{m} on s{r['seed']} {r['key']} ("
                           + ("failed" if v is None else
                              f"{v['surface_display_psnr_db']:.1f} dB") + ")")
    return out


def merge_rows(old_rows: list[dict], new_rows: list[dict]) -> list[dict]:
    """The old rows in their order, each replaced by the new row of the same seed and key,
    then the new rows of slots the old run did not have (in their corpus order)."""
    fresh = {(r["seed"], r["key"]): r for r in new_rows}
    seen = {(r["seed"], r["key"]) for r in old_rows}
    return ([fresh.get((r["seed"], r["key"]), r) for r in old_rows]
            + [r for r in new_rows if (r["seed"], r["key"]) not in seen])


def _previous_rows(a) -> tuple[list, dict] | str:
    """The rows and meta of <out>/fidelity.json for --update, or why they cannot be updated."""
    path = a.out / "fidelity.json"
    if not a.scenes:
        return "--update needs --scenes (the slots to re-measure)"
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        return f"--update: {path}: {e}"
    m = old.get("meta", {})
    for key, want in (("seeds", a.seed), ("size", a.size), ("spp", a.spp)):
        if m.get(key) != want:
            return f"--update: {path}: meta {key} is {m.get(key)!r}, this run's is {want!r}"
    return old["rows"], m


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sgpipe.experiments.fidelity",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out/figures/fidelity"))
    ap.add_argument("--seed", type=int, nargs="+", default=[REPORT_SEED])
    ap.add_argument("--scenes", nargs="+", default=None,
                    help="slot keys (default: all); --list prints them")
    ap.add_argument("--list", action="store_true", help="print the slot keys and exit")
    ap.add_argument("--size", type=int, default=96)
    ap.add_argument("--spp", type=int, default=1024, help="reference spp per seed (two seeds)")
    ap.add_argument("--quick", action="store_true", help="48², 64 spp: a smoke run")
    ap.add_argument("--results", type=Path, default=None,
                    help="Markdown report (default <out>/fidelity.md)")
    ap.add_argument("--update", action="store_true",
                    help="re-measure only --scenes and replace their rows in <out>/fidelity.json "
                         "(same seeds, size and spp); the report is rewritten from all rows")
    a = ap.parse_args(argv)
    if a.list:
        print("\n".join(s.key for s in SLOTS))
        return 0
    keys = {s.key for s in SLOTS}
    unknown = sorted(set(a.scenes or ()) - keys)
    if unknown:
        print(f"fidelity: error: --scenes: unknown slot {unknown[0]!r} (see --list)",
              file=sys.stderr)
        return 2
    if a.quick:
        a.size, a.spp = 48, 64
    previous = _previous_rows(a) if a.update else None
    if isinstance(previous, str):
        print(f"fidelity: error: {previous}", file=sys.stderr)
        return 2
    a.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rows = run_corpus(a.out, a.seed, size=a.size, spp=a.spp, only=a.scenes)
    meta = {"seeds": a.seed, "tuning_seeds": list(TUNING_SEEDS), "size": a.size, "spp": a.spp,
            "seconds": time.perf_counter() - t0, "goal_db": GOAL_DB,
            "goal_methods": list(GOAL_METHODS)}
    if previous is not None:
        old_rows, old_meta = previous
        rows = merge_rows(old_rows, rows)
        # "seconds" stays the whole corpus's time (the report's regenerate line)
        meta.update(seconds=old_meta["seconds"], updated_scenes=sorted(a.scenes),
                    update_seconds=meta["seconds"])
    (a.out / "fidelity.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    results = a.results or a.out / "fidelity.md"
    results.parent.mkdir(parents=True, exist_ok=True)
    meta["results"] = results.as_posix()
    results.write_text(report.markdown(rows, meta, goal_misses(rows)))
    # the numbers beside the page (docs/results/han07.md reads the report seed's)
    results.with_suffix(".json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    misses = goal_misses(rows)
    print(f"fidelity: {len(rows)} scenes in {meta['seconds'] / 60:.1f} min -> {results}")
    print(f"goal ≥ {GOAL_DB:.0f} dB surface for {' and '.join(GOAL_METHODS)} without normal "
          f"maps: " + ("met" if not misses else f"not met on {len(misses)}: "
                       + "; ".join(misses)))
    broken = [f"{r['key']}: {m}" for r in rows for m, e in r["errors"].items()
              if not e.startswith("BadInput")]
    for b in broken:
        print(f"fidelity: method failed (not a refusal): {b}", file=sys.stderr)
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
