"""Han07 Fig 2 / Fig 8's coloured, multi-material maps (eq 22): the grooves map with a colour
and specular strength per facet orientation (kd and ks textures made from its own normals),
the plane at 1–64× minification, `vmf` with colour features (`normalmap.colour_features`)
against the same `vmf` with the colour's plain MIP (J = 4 and 8 lobes), `vmf_han07` (eq 22 as
published), the single-lobe baselines and the reference. `python -m sgpipe.experiments.han07`
runs it (its report's "Coloured map" section); alone:

    python -m sgpipe.experiments.han07_colour --out out/figures/han07_colour
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from sgpipe.experiments import han07 as H

#: facet orientation → (kd multiplier, ks multiplier): the map's ±x and ±y facets and its flat
#: tops each get their own colour and specular strength
CLUSTERS = (((1, 0), (0.85, 0.18, 0.10), 1.0), ((-1, 0), (0.10, 0.25, 0.90), 0.15),
            ((0, 1), (0.15, 0.80, 0.15), 1.0), ((0, -1), (0.90, 0.75, 0.10), 0.15))
FLAT = ((0.5, 0.5, 0.5), 0.5)
MATERIAL = {"name": "painted", "model": "blinn_phong",
            "params": {"exponent": H.EXPONENT, "kd": 0.45, "ks": 0.5}}
METHODS = ("vmf", "vmf_han07", "toksvig", "normals_mip", "engine_bake", "nm_sh")
TARGET_DB = 6.0             # vmf with features over vmf with the colour's plain MIP
#: (column, lobes, colour features) of the vmf runs beside METHODS' (J = 4, features on)
VMF_RUNS = (("vmf_mip", 4, False), ("vmf8", 8, True), ("vmf8_mip", 8, False))


def colour_textures(normal_map: Path, out: Path) -> tuple[Path, Path]:
    """kd.png and ks.png (8-bit data textures: linear values) of the map's facet clusters
    (CLUSTERS) under `out`."""
    from sgpipe.io import write_png
    from sgpipe.normalmap.read import decode_normals, read_normal_texels
    n = decode_normals(read_normal_texels(normal_map, "normal_map"))
    kd = np.tile(np.asarray(FLAT[0]), n.shape[:2] + (1,))
    ks = np.full(n.shape[:2], FLAT[1])
    for (ax, ay), c, s in CLUSTERS:
        sel = ax * n[..., 0] + ay * n[..., 1] > 0.3
        kd[sel], ks[sel] = c, s
    out.mkdir(parents=True, exist_ok=True)
    for name, img in (("kd.png", kd), ("ks.png", np.repeat(ks[..., None], 3, 2))):
        write_png(out / name, np.round(img * 255).astype(np.uint8), already_8bit=True)
    return out / "kd.png", out / "ks.png"


def _config(scene, nmap, methods, kd, ks, features: bool, spp: int, lobes: int):
    from sgpipe.config.root import Config
    from sgpipe.config.schema import Context, build
    raw = H.raw_config(scene, nmap, list(methods), lobes=lobes, spp=spp, material=MATERIAL)
    raw["render"]["material_textures"] = [{"material": MATERIAL["name"], "kd_map": str(kd),
                                           "ks_map": str(ks)}]
    raw["normalmap"]["colour_features"] = features
    return build(Config, raw, (), Context(file=None, lines={}))


def cell(minification: float, *, size: int, spp: int, out: Path) -> dict:
    """{column: {image, psnr, flip} or {error}, "reference": {...}} of one minification;
    columns VMF_RUNS beside METHODS'."""
    nmap = H.DATA / H.MAPS["grooves"]
    kd, ks = colour_textures(nmap, out / "textures")
    scene = H.subject_scene("plane", minification, size, out / "meshes")
    return score_cell(lambda methods, features, lobes: _config(scene, nmap, methods, kd, ks,
                                                               features, spp, lobes),
                      out / "runs" / f"m{minification:g}")


def score_cell(config, runs: Path) -> dict:
    """One minification's cell of a coloured subject: `config(methods, features, lobes)` →
    its Config; METHODS and the reference with the features (J = DEFAULT_LOBES), then vmf per
    VMF_RUNS, each run under `runs`, scored against that reference."""
    r = H.render(config([*METHODS, "reference"], True, H.DEFAULT_LOBES), runs / "features")
    if "error" in r:
        return {c: {"error": r["error"]} for c in columns() + ["reference"]}
    ref, mask = r["reference"], r["_mask"]
    res = {"reference": {"image": ref, "stderr": r.get("_stderr"),
                         "mean": float(np.mean(ref[mask])) if mask.any() else None}}
    for m in METHODS:
        res[m] = H._score(r[m], ref, mask)
    for col, lobes, features in VMF_RUNS:
        p = H.render(config(["vmf"], features, lobes), runs / col)
        res[col] = p if "error" in p else H._score(p["vmf"], ref, mask)
    return res


def columns() -> list[str]:
    return ["vmf", "vmf_mip", "vmf8", "vmf8_mip", *METHODS[1:]]


def run(out: Path, *, size: int = 64, spp: int = 512, minifications=H.MINIFICATIONS,
        log=print) -> dict:
    """{minification: cell}."""
    return run_cells(cell, "coloured grooves plane", out, size=size, spp=spp,
                     minifications=minifications, log=log)


def run_cells(cell, subject: str, out: Path, *, size: int, spp: int, minifications,
              log) -> dict:
    """{minification: cell(m, size=, spp=, out=)}, each logged with its scores."""
    rows = {}
    for m in minifications:
        t0 = time.perf_counter()
        rows[m] = cell(m, size=size, spp=spp, out=out)
        log(f"[han07] {subject} {m:g}×: " + ", ".join(
            f"{c} {v['psnr']:.2f}" if "psnr" in v else f"{c} missing"
            for c, v in rows[m].items() if c != "reference")
            + f" dB ({time.perf_counter() - t0:.0f} s)")
    return rows


def targets(rows: dict) -> list[dict]:
    """vmf with colour features ≥ TARGET_DB over the same vmf with the plain MIP colour, per
    minification and lobe count."""
    out = []
    for m, c in rows.items():
        for feat, mip, j in (("vmf", "vmf_mip", 4), ("vmf8", "vmf8_mip", 8)):
            a, b = c.get(feat, {}).get("psnr"), c.get(mip, {}).get("psnr")
            if a is not None and b is not None:
                out.append({"name": f"{m:g}×: vmf (J = {j}) with colour features ≥ "
                            f"{TARGET_DB:g} dB over the same vmf with the colour's plain MIP",
                            "subject": "coloured grooves plane", "value": f"{a - b:+.2f} dB",
                            "met": a - b >= TARGET_DB})
    return out


def section(rows: dict) -> list[str]:
    """The report's Markdown section."""
    L = ["## Coloured map (Fig 2 / Fig 8, eq 22)", "",
         "The grooves map with a colour and specular strength per facet orientation: kd × "
         + ", ".join(f"({', '.join(f'{x:g}' for x in c)})" for _, c, _ in CLUSTERS)
         + " and ks × " + ", ".join(f"{s:g}" for _, _, s in CLUSTERS)
         + " on the +x, −x, +y, −y facets, grey kd × 0.5 and ks × 0.5 on the flat tops "
         f"(Blinn–Phong s = {H.EXPONENT:g}, kd 0.45, ks 0.5; `render.material_textures`), the "
         "plane of Fig 2 under its light. `vmf` / `vmf8`: J = 4 / 8 lobes with colour features "
         "(`normalmap.colour_features`, each lobe its own colour); `vmf_mip` / `vmf8_mip`: the "
         "same with the colour's plain MIP (features off); `vmf_han07`: Han07 as published "
         "(J = 4, eq 22 through its trilinear lookup). Cells: "
         "surface display PSNR (dB) / LDR-ꟻLIP against the reference.", ""]
    return L + table(rows)


def table(rows: dict) -> list[str]:
    """The cells' Markdown table (columns()), then a blank line."""
    from sgpipe.experiments.han07_report import _f
    cols = columns()
    L = ["| minification | " + " | ".join(cols) + " |", "|---|" + "---|" * len(cols)]
    for m, c in rows.items():
        L.append(f"| {m:g}× | " + " | ".join(
            f"{_f(c[k]['psnr'])} / {_f(c[k]['flip'], '{:.3f}')}" if "psnr" in c.get(k, {})
            else "missing" for k in cols) + " |")
    return L + [""]


def standalone(argv, module, name: str) -> int:
    """A coloured subject's command line (`module`: its run, section and targets): its section
    and targets to stdout and `<out>/<name>.md`."""
    ap = argparse.ArgumentParser(description=module.__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(f"out/figures/{name}"))
    ap.add_argument("--minifications", default=",".join(f"{m:g}" for m in H.MINIFICATIONS))
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    rows = module.run(a.out, minifications=tuple(float(m) for m in a.minifications.split(",")),
                      log=lambda s: print(s, file=sys.stderr, flush=True))
    lines = module.section(rows) + ["| target | value | met |", "|---|---|---|"] + [
        f"| {t['name']} | {t['value']} | {'met' if t['met'] else 'no'} |"
        for t in module.targets(rows)]
    (a.out / f"{name}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


def main(argv=None) -> int:
    return standalone(argv, sys.modules[__name__], "han07_colour")


if __name__ == "__main__":
    sys.exit(main())
