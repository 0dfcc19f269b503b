"""Han07's experiments: the paper's Fig 2, 7 and 3 and the quality targets.

    python -m sgpipe.experiments.han07 --out out/figures/han07 [--quick]

Fig 2: a normal-mapped plane and UV sphere seen head-on at 1×, 4×, 16× and 64× minification
(texels per pixel along the image axis at the image centre), rendered through the real stages
(fit → precompute → render) by the vMF method with J = 1, 2, 4, 8 lobes and the single-lobe
baselines of `sgpipe.render.methods.METHODS` (toksvig, normals_mip, and engine_bake / nm_sh when
registered), against the Monte Carlo reference of the unfiltered map box-filtered over each
pixel; display PSNR and LDR-ꟻLIP on the surface pixels. The minification is the meshes' UV
tiling (OBJs with scaled `vt` written under <out>/meshes). Fig 7: one coarse texel's NDF
against its J-lobe fit (J = 1…8): band-limited NDF error (l ≤ 8) and the error of a lit-sphere
image of its effective Blinn–Phong BRDF (han07_ndf). Fig 3: Lambertian SH (l ≤ 2) per MIP level
(NDF side) and, when `nm_sh` is registered, a receding plane. Writes contact sheets and PNG plots
under <out> and the Markdown report (default docs/results/han07.md, sheets beside it in
docs/results/figures/; `--quick`, a ≤ 60 s smoke run, writes <out>/han07.md instead). A render that fails is reported as missing with its error, never faked.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from sgpipe.experiments import han07_ndf as ndf
from sgpipe.experiments.han07_report import write_report

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data_samples"
MAPS = {"grooves": "grooves_normal.png", "bumps": "normal_map.png"}
MINIFICATIONS = (1, 4, 16, 64)
LOBES = (1, 2, 4, 8)
DEFAULT_LOBES = 4                         # the `normalmap.lobes` default: "the vMF method"
BASELINES = ("toksvig", "normals_mip", "engine_bake", "nm_sh")
EXPONENT = 60.0                           # Blinn–Phong s of the material (eq 20's lobe)
MATERIAL = {"name": "glossy", "model": "blinn_phong",
            "params": {"exponent": EXPONENT, "kd": 0.15, "ks": 0.85}}
# world direction towards the light: 60° from the plane's normal (+y), so that ω_h sits 30° off
# it, between the caps' tilts (0–53°) and the grooves' 37°
LIGHT_PLANE = (0.75, 0.5, 0.433)
LIGHT_SPHERE = (0.55, 0.45, 0.70)
IRRADIANCE = 1.5


def _defaults() -> tuple[str, int]:
    """The product's render.normalmap_footprint and normalmap.bilinear_samples defaults, which
    the experiment runs unless told otherwise."""
    import dataclasses

    from sgpipe.config.sections.normalmap import NormalmapSection
    from sgpipe.config.sections.render import RenderSection
    foot = next(f.default for f in dataclasses.fields(RenderSection)
                if f.name == "normalmap_footprint")
    return foot, NormalmapSection().bilinear_samples


FOOTPRINT, BILINEAR_SAMPLES = _defaults()
PLANE_FOV = 20.0                          # the plane's central 2 × 2 of its 6 × 6 fills the frame
SPHERE_EYE, SPHERE_FOV = 4.0, 32.0


def columns() -> list[str]:
    """Fig 2's method columns: vmf1 … vmf8, then the registered baselines."""
    from sgpipe.render.methods import METHODS
    return [f"vmf{j}" for j in LOBES] + [b for b in BASELINES if b in METHODS]


def missing_baselines() -> list[str]:
    from sgpipe.render.methods import METHODS
    return [b for b in BASELINES if b not in METHODS]


# -- scenes ----------------------------------------------------------------------------------

def tiled_obj(src: Path, dst: Path, ru: float, rv: float) -> Path:
    """`src` with every `vt` multiplied by (ru, rv) (repeat addressing tiles the map)."""
    out = []
    for line in src.read_text().splitlines():
        if line.startswith("vt "):
            u, v = (float(t) for t in line.split()[1:3])
            line = f"vt {u * ru:.7f} {v * rv:.7f}"
        out.append(line)
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_text("\n".join(out) + "\n")
    return dst


def subject_scene(subject: str, minification: float, size: int, work: Path) -> dict:
    """(object, camera, light) of one Fig 2 cell; the UV tiling gives `minification` texels per
    pixel at the image centre (256² maps)."""
    if subject == "plane":      # floor.obj: 6 × 6, vt over [0, 1]; the frame sees its central 2
        rep = 3.0 * size * minification / 256.0
        mesh = tiled_obj(DATA / "floor.obj", work / f"plane_m{minification:g}.obj", rep, rep)
        d = 1.0 / math.tan(math.radians(PLANE_FOV / 2))
        cam = {"eye": [0.0, d, 0.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
               "fov_deg": PLANE_FOV}
        light = LIGHT_PLANE
    else:                       # sphere.obj: unit UV sphere, u = φ/2π, v = 1 − θ/π
        pix = 2.0 * (SPHERE_EYE - 1.0) * math.tan(math.radians(SPHERE_FOV / 2)) / size
        ru = 2.0 * math.pi * minification / (256.0 * pix)        # equator texel = pixel · m
        mesh = tiled_obj(DATA / "sphere.obj", work / f"sphere_m{minification:g}.obj", ru,
                         ru / 2.0)
        cam = {"eye": [0.0, 0.0, SPHERE_EYE], "target": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0],
               "fov_deg": SPHERE_FOV}
        light = LIGHT_SPHERE
    cam.update(width=size, height=size)
    return {"mesh": str(mesh), "camera": cam, "light": light}


def build_config(scene: dict, normal_map: Path, methods: list[str], **kw):
    """A validated root Config of `raw_config` (through the schema, as a YAML file would be)."""
    from sgpipe.config.root import Config
    from sgpipe.config.schema import Context, build
    return build(Config, raw_config(scene, normal_map, methods, **kw), (),
                 Context(file=None, lines={}))


def raw_config(scene: dict, normal_map: Path, methods: list[str], *, lobes: int, spp: int,
               material: dict = MATERIAL, light_scale: float = 1.0, taps: int = 8,
               footprint: str = FOOTPRINT, bilinear_samples: int = BILINEAR_SAMPLES) -> dict:
    """One Fig 2 cell's config as a YAML file would hold it."""
    return {
        "name": "han07", "seed": 0,
        "scene": {"objects": [{"name": "surface", "mesh": scene["mesh"],
                               "material": material["name"], "normal_map": str(normal_map)}]},
        "fit": {"materials": [{"name": material["name"], "model": material["model"],
                               "params": dict(material["params"])}]},
        "normalmap": {"lobes": int(lobes), "bilinear_samples": int(bilinear_samples)},
        "render": {"camera": scene["camera"], "methods": list(methods), "spp": spp,
                   "background": False, "supersample": 1, "normalmap_max_taps": taps,
                   "normalmap_footprint": footprint,
                   "lights": [{"type": "directional", "direction": list(scene["light"]),
                               "intensity": [IRRADIANCE * light_scale] * 3}]},
    }


def _why(e: BaseException) -> str:
    from sgpipe.errors import BadInput
    msg = e.one_line() if isinstance(e, BadInput) else str(e)
    return f"{type(e).__name__}: {(msg.splitlines() or [''])[0][:160]}"


def render(cfg, work: Path) -> dict:
    """fit → precompute → render in `work` (stages skip what is unchanged); {method: image} or
    {"error": reason}."""
    import importlib
    from contextlib import redirect_stderr, redirect_stdout
    from io import StringIO

    from sgpipe.artifacts.render import read_gbuffer, read_image
    from sgpipe.metrics import surface_mask
    try:
        with redirect_stdout(StringIO()), redirect_stderr(StringIO()):   # the stages' logs
            for stage in ("fit", "precompute", "render"):
                importlib.import_module(f"sgpipe.stages.{stage}").run(cfg, work)
    except Exception as e:  # noqa: BLE001 - reported as "missing", never hidden
        return {"error": _why(e)}
    rdir = work / "render"
    out = {m: read_image(rdir, m) for m in cfg.render.methods}
    if "reference" in out:      # its Monte Carlo noise: the mean standard error per pixel
        man = json.loads((rdir / "manifest.json").read_text())
        out["_stderr"] = man.get("report", {}).get("reference_mean_stderr")
    out["_mask"] = surface_mask(read_gbuffer(rdir).object_id)
    return out


def _score(img, ref, mask) -> dict:
    from sgpipe.metrics import compare_images
    d = compare_images(img, ref, surface=mask)
    return {"image": img, "psnr": d["surface"]["display_psnr_db"],
            "flip": d["surface"]["flip_ldr"]}


def fig2_cell(map_name: str, subject: str, minification: float, *, size: int, spp: int,
              out: Path, lobes=LOBES, footprint: str = FOOTPRINT,
              bilinear_samples: int = BILINEAR_SAMPLES) -> dict:
    """Every column of one (map, subject, minification) cell: {column: {image, psnr, flip} or
    {error}, "reference": {image}}."""
    nmap = DATA / MAPS[map_name]
    scene = subject_scene(subject, minification, size, out / "meshes")
    cols = columns()
    res: dict = {}
    runs = out / "runs" / map_name
    # the default lobe count renders the reference and the original baselines with it
    main = [b for b in ("toksvig", "normals_mip") if b in cols]
    variant = dict(footprint=footprint, bilinear_samples=bilinear_samples)
    r = render(build_config(scene, nmap, ["vmf", *main, "reference"], lobes=DEFAULT_LOBES,
                            spp=spp, **variant), runs / f"J{DEFAULT_LOBES}")
    if "error" in r:
        return {c: {"error": r["error"]} for c in cols + ["reference"]}
    ref, mask = r["reference"], r["_mask"]
    res["reference"] = {"image": ref, "stderr": r.get("_stderr"),
                        "mean": float(np.mean(ref[mask])) if mask.any() else None}
    res[f"vmf{DEFAULT_LOBES}"] = _score(r["vmf"], ref, mask)
    for b in main:
        res[b] = _score(r[b], ref, mask)
    for j in lobes:
        if j == DEFAULT_LOBES:
            continue
        if not (runs / f"J{j}" / "fit").is_dir():    # the same fit: reuse it (skipped as done)
            shutil.copytree(runs / f"J{DEFAULT_LOBES}" / "fit", runs / f"J{j}" / "fit")
        rj = render(build_config(scene, nmap, ["vmf"], lobes=j, spp=spp, **variant),
                    runs / f"J{j}")
        res[f"vmf{j}"] = rj if "error" in rj else _score(rj["vmf"], ref, mask)
    for b in cols:              # the later baselines on their own: a failure stays theirs
        if b in res or b.startswith("vmf"):
            continue
        rb = render(build_config(scene, nmap, [b], lobes=DEFAULT_LOBES, spp=spp,
                                 **variant), runs / f"J{DEFAULT_LOBES}")
        res[b] = rb if "error" in rb else _score(rb[b], ref, mask)
    return res


def fig2(out: Path, subjects, *, size: int, spp: int, minifications=MINIFICATIONS,
         lobes=LOBES, log=print, footprint: str = FOOTPRINT,
         bilinear_samples: int = BILINEAR_SAMPLES) -> dict:
    """{(map, subject): {minification: cell}}."""
    table = {}
    for map_name, subject in subjects:
        table[(map_name, subject)] = {}
        for m in minifications:
            t0 = time.perf_counter()
            cell = fig2_cell(map_name, subject, m, size=size, spp=spp, out=out, lobes=lobes,
                             footprint=footprint, bilinear_samples=bilinear_samples)
            table[(map_name, subject)][m] = cell
            log(f"[han07] Fig 2 {map_name} {subject} {m:g}×: " + ", ".join(
                f"{c} {v['psnr']:.2f}" if "psnr" in v else f"{c} missing"
                for c, v in cell.items() if c != "reference")
                + f" dB ({time.perf_counter() - t0:.0f} s)")
    return table


# -- targets ---------------------------------------------------------------------------------

def targets(table: dict) -> list[dict]:
    """The issue's quality targets per Fig 2 subject: {name, subject, value, met}."""
    out = []
    v = f"vmf{DEFAULT_LOBES}"

    def psnr(cell, c):
        return cell.get(c, {}).get("psnr")

    for (map_name, subject), rows in table.items():
        key = f"{map_name} {subject}"
        if 16 in rows:
            c = rows[16]
            for base, need in (("toksvig", 6.0), ("normals_mip", 10.0)):
                a, b = psnr(c, v), psnr(c, base)
                if a is not None and b is not None:
                    out.append({"name": f"16×: vMF (J = 4) ≥ {need:g} dB over {base}",
                                "subject": key, "value": f"{a - b:+.2f} dB",
                                "met": a - b >= need})
        if 1 in rows:
            ps = {c: p for c, p in ((c, psnr(rows[1], c)) for c in rows[1]) if p is not None}
            # nm_sh above level 0: l ≤ 4 cannot hold the s = 60 lobe (the sphere's rim)
            for label, keep in (("every method", ps), ("every method but nm_sh",
                                                       {c: p for c, p in ps.items()
                                                        if c != "nm_sh"})):
                if len(keep) < 2 or (keep is not ps and len(keep) == len(ps)):
                    continue
                best = max(keep.values())
                out_of = [f"{c} {p:.2f}" for c, p in keep.items() if best - p > 1.0]
                out.append({"name": f"1×: {label} within 1 dB of the others",
                            "subject": key, "value": f"{min(keep.values()):.2f}–{best:.2f} dB"
                            + (f"; outside: {', '.join(out_of)}" if out_of else ""),
                            "met": not out_of})
        for m, c in rows.items():
            a, b = psnr(c, "vmf4"), psnr(c, "vmf8")
            if a is not None and b is not None:
                out.append({"name": f"{m:g}×: 4 lobes within 0.5 dB of 8", "subject": key,
                            "value": f"{a - b:+.2f} dB", "met": abs(a - b) <= 0.5})
    return out


# -- outputs ---------------------------------------------------------------------------------

def fig2_sheet(path: Path, rows: dict) -> Path:
    """Rows = minifications: reference, then per column image + false-colour difference."""
    from sgpipe.experiments.sheets import contact_sheet
    cols = columns()
    def up(v):                  # 3× nearest-neighbour: the 64² tiles readable in a page
        if "image" not in v:
            return v
        return {**v, "image": np.repeat(np.repeat(v["image"], 3, axis=0), 3, axis=1)}
    data = [(f"{m:g}x", {k: up(v) for k, v in cell.items()}) for m, cell in rows.items()
            if "image" in cell.get("reference", {})]
    if not data:
        return path
    return contact_sheet(path, data, cols)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out/figures/han07"))
    ap.add_argument("--results", type=Path, default=None,
                    help="Markdown report (default docs/results/han07.md; with --quick "
                         "<out>/han07.md, so that a smoke run never replaces the figures).")
    ap.add_argument("--quick", action="store_true",
                    help="Smoke run (≤ 60 s): grooves plane at 16× only, 32², 64 spp; Fig 7 on "
                         "one cell.")
    ap.add_argument("--footprint", choices=("trilinear", "box"), default=FOOTPRINT,
                    help="render.normalmap_footprint of every normal-map method.")
    ap.add_argument("--bilinear-samples", type=int, choices=(1, 2, 4), default=BILINEAR_SAMPLES,
                    help="normalmap.bilinear_samples: pyramid levels ≥ 1 from s×s sub-samples "
                         "per texel of the bilinear map.")
    ap.add_argument("--subjects", default=None,
                    help="Fig 2 only, for these map:subject pairs (e.g. grooves:sphere,"
                         "bumps:plane) at --minifications; writes <out>/han07_fig2.md and "
                         "<out>/han07_fig2.json, never the report.")
    ap.add_argument("--minifications", default=",".join(f"{m:g}" for m in MINIFICATIONS),
                    help="With --subjects: comma-separated minifications.")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    a.out.mkdir(parents=True, exist_ok=True)

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    if a.subjects:
        return fig2_only(a, log)
    if a.results is None:
        a.results = a.out / "han07.md" if a.quick else ROOT / "docs" / "results" / "han07.md"
    f7 = ndf.fig7(a.out, full=not a.quick, log=log)
    f3 = ndf.fig3_ndf(full=not a.quick)
    size, spp = (32, 64) if a.quick else (64, 512)
    if a.quick:
        table = fig2(a.out, [("grooves", "plane")], size=size, spp=spp, minifications=(16,),
                     lobes=(4, 8), log=log, footprint=a.footprint,
                     bilinear_samples=a.bilinear_samples)
    else:
        table = fig2(a.out, [("grooves", "plane"), ("grooves", "sphere"), ("bumps", "plane")],
                     size=size, spp=spp, log=log, footprint=a.footprint,
                     bilinear_samples=a.bilinear_samples)
    f3r = None if a.quick else ndf.fig3_render(a.out, log=log)
    from sgpipe.experiments import han07_colour as HC
    colour = HC.run(a.out / "colour", size=size, spp=spp,
                    minifications=(16,) if a.quick else MINIFICATIONS, log=log)
    from sgpipe.experiments import han07_material as HM
    material = HM.run(a.out / "material", size=size, spp=spp,
                      minifications=(16,) if a.quick else MINIFICATIONS, log=log)
    tg = targets(table) + HC.targets(colour) + HM.targets(material)
    fig_dir = a.results.parent / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    sheets = []
    for (map_name, subject), rows in table.items():
        name = f"han07_fig2_{map_name}_{subject}.png"
        if fig2_sheet(a.out / name, rows).is_file():
            shutil.copyfile(a.out / name, fig_dir / name)
            sheets.append((f"{map_name} {subject}", f"figures/{name}"))
    for name in f7.get("pngs", []) + (f3r or {}).get("pngs", []):
        shutil.copyfile(a.out / name, fig_dir / name)
    summary = {"fig2": {f"{k[0]} {k[1]}": {f"{m:g}": {c: {x: v[x] for x in ("psnr", "flip",
                                                                              "error") if x in v}
                                                         for c, v in cell.items()
                                                         if c != "reference"}
                                             for m, cell in rows.items()}
                        for k, rows in table.items()},
               "fig7": f7["rows"], "fig3_ndf": f3, "fig3_render": (f3r or {}).get("rows"),
               **{name: {f"{m:g}": {c: {x: v[x] for x in ("psnr", "flip", "error") if x in v}
                                    for c, v in cell.items() if c != "reference"}
                         for m, cell in rows.items()}
                  for name, rows in (("colour", colour), ("material", material))},
               "targets": tg}
    (a.out / "han07.json").write_text(json.dumps(summary, indent=1, default=float) + "\n")
    write_report(a.results, table, f7, f3, f3r, tg, sheets, columns(), missing_baselines(),
                 size=size, spp=spp, seconds=time.perf_counter() - t0, quick=a.quick,
                 footprint=a.footprint, bilinear_samples=a.bilinear_samples,
                 colour=HC.section(colour) + HM.section(material),
                 command="python -m sgpipe.experiments.han07 " + " ".join(
                     sys.argv[1:] if argv is None else argv))
    for t in tg:
        log(f"[han07] target {'MET' if t['met'] else 'NOT MET'}: {t['name']} — {t['subject']}: "
            f"{t['value']}")
    log(f"[han07] wrote {a.results} in {time.perf_counter() - t0:.0f} s")
    failed = sum("error" in v for rows in [*table.values(), colour, material]
                 for cell in rows.values() for v in cell.values())
    if failed:
        log(f"[han07] {failed} renders failed (named in the report)")
    return 1 if failed else 0


def fig2_only(a, log) -> int:
    """`--subjects`: the Fig 2 cells of the named map:subject pairs, their targets, a Markdown
    table and JSON under <out>."""
    from sgpipe.experiments.han07_report import _fig2_tables
    t0 = time.perf_counter()
    pairs = []
    for item in a.subjects.split(","):
        map_name, _, subject = item.strip().partition(":")
        if map_name not in MAPS or subject not in ("plane", "sphere"):
            raise SystemExit(f"--subjects: {item!r} is not map:subject with map in "
                             f"{sorted(MAPS)} and subject plane or sphere")
        pairs.append((map_name, subject))
    mins = tuple(float(m) for m in a.minifications.split(","))
    table = fig2(a.out, pairs, size=64, spp=512, minifications=mins, log=log,
                 footprint=a.footprint, bilinear_samples=a.bilinear_samples)
    tg = targets(table)
    lines = [f"# Han07 Fig 2 cells (render.normalmap_footprint: {a.footprint})", "",
             f"`python -m sgpipe.experiments.han07 --out {a.out} --subjects {a.subjects} "
             f"--minifications {a.minifications} --footprint {a.footprint} "
             f"--bilinear-samples {a.bilinear_samples}` in "
             f"{time.perf_counter() - t0:.0f} s; cells: surface display PSNR (dB) / LDR-ꟻLIP.",
             ""] + _fig2_tables(table, columns()) + [
             "| target | subject | value | met |", "|---|---|---|---|"] + [
             f"| {t['name']} | {t['subject']} | {t['value']} | {'met' if t['met'] else 'no'} |"
             for t in tg]
    (a.out / "han07_fig2.md").write_text("\n".join(lines) + "\n")
    summary = {f"{k[0]} {k[1]}": {f"{m:g}": {c: {x: v[x] for x in ("psnr", "flip", "error")
                                                   if x in v}
                                              for c, v in cell.items() if c != "reference"}
                                  for m, cell in rows.items()} for k, rows in table.items()}
    (a.out / "han07_fig2.json").write_text(json.dumps({"fig2": summary, "targets": tg},
                                                      indent=1, default=float) + "\n")
    log(f"[han07] wrote {a.out / 'han07_fig2.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
