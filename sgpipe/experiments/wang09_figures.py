"""Wang09 §5 and §8 on sgpipe's teapot scene (data_samples/teapot.obj on floor.obj, Cook–Torrance
teapot, the studio map) through the real stages: Fig 7 (SG × SSDF product against ray tracing,
by lobe sharpness λ), Fig 9 (SSDF error against PCA terms) and Table 1's columns (vertices,
environment SG lobes, SSDF sampling and compression time, SSDF storage, frame rates of `sg` and
`sg_wang09` with the environment alone and with two point lights)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data_samples"
#: Wang09 Table 1's teapot: 30 PCA terms
PCA_TERMS = 30
LAMBDAS = (4.0, 16.0, 64.0, 256.0, 1024.0)
FRAME = 512                     # Table 1's frame rates: one 512² frame, no supersampling
POINT_LIGHTS = [{"type": "point", "position": [-2.0, 3.2, 1.6], "intensity": [8, 8, 8],
                 "radius": 0.05},
                {"type": "point", "position": [2.5, 2.0, -1.0], "intensity": [5, 4, 3],
                 "radius": 0.05}]


def config(*, lights: bool, seed: int = 0, workers: int = 0):
    """The teapot scene as a validated root Config."""
    from sgpipe.experiments.corpus.measure import load_scene
    raw = {
        "name": "wang09-teapot", "seed": seed, "workers": workers,
        "scene": {"objects": [
            {"name": "teapot", "mesh": str(DATA / "teapot.obj"), "material": "teapot"},
            {"name": "floor", "mesh": str(DATA / "floor.obj"), "material": "floor"}]},
        "fit": {"materials": [
            {"name": "teapot", "model": "cook_torrance",
             "params": {"m": 0.2, "kd": [0.3, 0.1, 0.05], "ks": 1.0}},
            {"name": "floor", "model": "lambert", "params": {"kd": [0.55, 0.52, 0.48]}}],
            "ndf_sg": {"report_lobes": 0}, "view_gmm": {"enabled": False}},
        "envmap": {"environment": str(DATA / "studio.exr")},
        "visibility": {"trace_resolution": 64, "resolution": 32, "pca_terms": PCA_TERMS,
                       "report_vertices": 24, "report_directions": 8,
                       "report_lambdas": list(LAMBDAS), "preview_vertices": 0},
        "render": {"camera": {"eye": [2.4, 1.9, 3.3], "target": [0, 0.42, 0], "fov_deg": 34,
                              "width": FRAME, "height": FRAME},
                   "methods": ["sg", "sg_wang09"], "timing_repeats": 5,
                   "lights": POINT_LIGHTS if lights else []},
    }
    return load_scene(raw)


def _bytes(folder: Path, pattern: str) -> int:
    return sum(p.stat().st_size for p in folder.rglob(pattern) if p.is_file())


def measure(out: Path, *, workers: int = 0, log=print) -> dict:
    """Run fit, precompute and the two renders; collect Fig 7, Fig 9 and Table 1's numbers."""
    from sgpipe.experiments.corpus.measure import run_stage
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    env_cfg = config(lights=False, workers=workers)
    for s in ("fit", "precompute"):
        log(f"[wang09] {s}")
        run_stage(s, env_cfg, out)
    vis = json.loads((out / "visibility" / "report.json").read_text())
    vt = json.loads((out / "visibility" / "timings.json").read_text())
    fps = {}
    for label, lights in (("env", False), ("points", True)):
        log(f"[wang09] render ({label})")
        run_stage("render", config(lights=lights, workers=workers), out)
        t = json.loads((out / "render" / "timings.json").read_text())
        fps[label] = {m: 1.0 / float(t[f"{m}_s"]) for m in ("sg", "sg_wang09")}
    objects = vis["objects"]
    pca_s = sum(float(v) for k, v in vt.items() if k.startswith("pca_s."))
    table = {
        "vertices": int(sum(o["vertices"] for o in objects.values())),
        "env_lobes": int(env_cfg.envmap.sg_lobes),
        "ssdf_sampling_s": float(vt["trace_wall_s"]),
        "pca_terms": PCA_TERMS, "pca_s": pca_s,
        "ssdf_bytes": _bytes(out / "visibility", "ssdf_pca.npz"),
        "fps": fps,
    }
    return {"table": table, "products": vis["products_all_objects"],
            "pca": {name: o["pca_error_vs_terms"] for name, o in objects.items()},
            "seconds": time.perf_counter() - t0}


_PRODUCT_SERIES = (("err_exact_raw", "exact f_h, SSDF as sampled"),
                   ("err_exact_pca", f"exact f_h, SSDF from {PCA_TERMS} PCA terms"),
                   ("err_sigmoid_pca", "sigmoid f_h (refitted), PCA"),
                   ("err_sigmoid_published_pca", "sigmoid f_h (printed coefficients), PCA"))


def plot_products(products: dict, path: Path) -> None:
    """Fig 7: mean and RMS |∫G·V − μ f_h(θ_d, λ)| / f_h(π/2, λ) against λ, per f_h and SSDF."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    lams = sorted(float(k) for k in products)
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for key, label in _PRODUCT_SERIES:
        y = [products[_key(products, lam)][key]["rms"] for lam in lams]
        ax.plot(lams, y, marker="o", label=label)
    ax.set_xscale("log")
    ax.set_xlabel("SG sharpness λ")
    ax.set_ylabel("RMS error / f_h(π/2, λ)")
    ax.set_title("Wang09 Fig 7: SG × SSDF product vs ray tracing (teapot + floor)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_pca(pca: dict, path: Path) -> None:
    """Fig 9: RMS SSDF error (radians) and sign mismatch against the number of PCA terms."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(9.0, 3.6))
    for name, curve in pca.items():
        terms = sorted(int(k) for k in curve)
        a.plot(terms, [curve[str(t)]["rms_rad"] for t in terms], marker="o", label=name)
        b.plot(terms, [100 * curve[str(t)]["sign_mismatch"] for t in terms], marker="o",
               label=name)
    a.set_xlabel("PCA terms")
    a.set_ylabel("RMS SSDF error (rad)")
    b.set_xlabel("PCA terms")
    b.set_ylabel("visibility sign mismatch (% of texels)")
    for ax in (a, b):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Wang09 Fig 9: PCA compression of SSDFs")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _key(d: dict, lam: float) -> str:
    return next(k for k in d if abs(float(k) - lam) < 1e-9)


def markdown(res: dict, fig7: str, fig9: str) -> list[str]:
    """The figures' section of docs/results/wang09.md."""
    t = res["table"]
    out = ["## Wang09's experiment on the teapot scene", "",
           f"The teapot of data_samples (Cook–Torrance m 0.2) on the tessellated floor under the "
           f"studio map, through the real stages (`sgpipe.experiments.wang09_figures`; "
           f"{res['seconds']:.0f} s): visibility traced at 64² per vertex, SSDFs at 32², "
           f"{PCA_TERMS} PCA terms (Table 1's teapot).", "",
           "### Table 1's columns", "",
           "| vertices | # E.L. | SSDF sampling | SSDF compression | SSDF size | Env. FPS sg / "
           "sg_wang09 | Pt. FPS sg / sg_wang09 |", "|---|---|---|---|---|---|---|",
           f"| {t['vertices']} | {t['env_lobes']} | {t['ssdf_sampling_s']:.1f} s | "
           f"{t['pca_terms']}D ({t['pca_s']:.1f} s) | {t['ssdf_bytes'] / 2 ** 20:.1f} MB | "
           f"{t['fps']['env']['sg']:.1f} / {t['fps']['env']['sg_wang09']:.1f} | "
           f"{t['fps']['points']['sg']:.1f} / {t['fps']['points']['sg_wang09']:.1f} |", "",
           f"Frame rates: one {FRAME}² frame on this machine's CPU (PoCL), warm, fastest of 5; "
           "Pt.: the environment and two point lights. The paper's numbers are a GeForce "
           "8800 Ultra's.", "",
           "### Fig 7: SG × SSDF products against ray tracing", "",
           f"![Fig 7]({fig7})", "",
           "Per lobe sharpness λ: the ray-traced ∫G(i; p, λ) V(i) di against μ f_h(θ_d(p), λ) "
           "at sample vertices (partly occluded ones first) and lobe axes above the horizon, "
           "errors divided by f_h(π/2, λ).", "",
           "| λ | " + " | ".join(label for _, label in _PRODUCT_SERIES) + " |",
           "|---|" + "---|" * len(_PRODUCT_SERIES)]
    prods = res["products"]
    for lam in sorted(float(k) for k in prods):
        e = prods[_key(prods, lam)]
        out.append(f"| {lam:g} | " + " | ".join(
            f"{e[k]['rms']:.4f} (max {e[k]['max_abs']:.3f})" for k, _ in _PRODUCT_SERIES)
            + " |")
    out += ["", "### Fig 9: PCA compression of the SSDFs", "", f"![Fig 9]({fig9})", "",
            "| object | " + " | ".join(f"{m} terms" for m in _terms(res["pca"])) + " |",
            "|---|" + "---|" * len(_terms(res["pca"]))]
    for name, curve in res["pca"].items():
        out.append(f"| {name} (RMS rad / sign %) | " + " | ".join(
            f"{curve[str(m)]['rms_rad']:.3f} / {100 * curve[str(m)]['sign_mismatch']:.1f}"
            if str(m) in curve else "—" for m in _terms(res["pca"])) + " |")
    return out + [""]


def _terms(pca: dict) -> list[int]:
    return sorted({int(k) for c in pca.values() for k in c})


def write_figures(res: dict, results: Path) -> list[str]:
    """Plots beside the results page (results/figures/wang09_fig*.png) + its markdown lines."""
    figs = results.parent / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    plot_products(res["products"], figs / "wang09_fig7.png")
    plot_pca(res["pca"], figs / "wang09_fig9.png")
    return markdown(res, "figures/wang09_fig7.png", "figures/wang09_fig9.png")
