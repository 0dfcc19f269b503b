"""The report's own charts, drawn by matplotlib from the run's numbers (deterministic PNGs via
sgpipe.fit.plot): metrics per method, frame times, fit error per view, SSDF PCA error."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.fit.plot import new_figure, save_png, style
from sgpipe.report.collect import Picture, Run, png_size

PLOTS = "assets/plots"


def _nan(v) -> float:
    return float("nan") if v is None else float(v)


def _bars(ax, names: list[str], groups: dict[str, list[float]], ylabel: str, title: str,
          fmt: str):
    """Grouped vertical bars: one group per name, one bar per series of `groups`."""
    x = np.arange(len(names))
    width = 0.8 / max(len(groups), 1)
    for k, (label, vals) in enumerate(groups.items()):
        bars = ax.bar(x + (k - (len(groups) - 1) / 2) * width, vals, width, label=label)
        ax.bar_label(bars, fmt=fmt, fontsize=7, padding=1)
    ax.set_xticks(x, names)
    ax.set_xlabel("method")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.margins(y=0.3)                                # room for the legend above the bars
    ax.legend(loc="upper center", ncol=len(groups))


def metrics_figure(run: Run):
    """Display PSNR and LDR-ꟻLIP of each method against the truth, whole frame and surfaces."""
    rows = [r for r in run.methods if r.metrics]
    if not rows:
        return None
    names = [r.method for r in rows]
    surf = [r.metrics.get("surface") or {} for r in rows]
    fig = new_figure(8.0, 3.4)
    ax1, ax2 = fig.subplots(1, 2)
    _bars(ax1, names, {"whole frame": [_nan(r.metrics.get("display_psnr_db")) for r in rows],
                       "surfaces": [_nan(s.get("display_psnr_db")) for s in surf]},
          "display PSNR (dB, higher is better)", f"display PSNR vs {run.render_facts['truth']}",
          "%.2f")
    _bars(ax2, names, {"whole frame": [_nan(r.metrics.get("flip_ldr")) for r in rows],
                       "surfaces": [_nan(s.get("flip_ldr")) for s in surf]},
          "LDR-ꟻLIP (lower is better)", f"LDR-ꟻLIP vs {run.render_facts['truth']}", "%.4f")
    fig.tight_layout()
    return fig


def timings_figure(run: Run):
    """Milliseconds per frame of each method (and the Monte Carlo truth's whole render)."""
    rows = [(r.method, r.seconds) for r in run.methods if r.seconds is not None]
    ref_s = run.render_facts.get("reference_s")
    if ref_s is not None and run.truth is not None:
        rows.append((f"{run.truth.method}\n({run.render_facts.get('spp')} spp, one render)",
                     ref_s))
    if not rows:
        return None
    fig = new_figure(6.0, 0.5 + 0.45 * len(rows) + 0.8)
    ax = fig.add_subplot()
    y = np.arange(len(rows))
    bars = ax.barh(y, [1e3 * s for _, s in rows], color="tab:blue")
    ax.bar_label(bars, labels=[f"{1e3 * s:.4g} ms" for _, s in rows], fontsize=7, padding=2)
    ax.set_yticks(y, [n for n, _ in rows])
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("milliseconds per frame (log scale; best of the warm launches)")
    ax.set_ylabel("method")
    ax.set_title("render time per frame (wall clock)")
    ax.margins(x=0.25)
    fig.tight_layout()
    return fig


def fit_views_figure(run: Run):
    """Per material: the vMF mixture's relative L2 error at each fitted view elevation (max over
    φ), and at held-out views halfway between them when the fit stage measured those."""
    mats = [m for m in run.materials if (m.report.get("view_gmm") or {}).get("rel_l2_per_theta")]
    if not mats:
        return None
    fig = new_figure(6.0, 3.6)
    ax = fig.add_subplot()
    for k, m in enumerate(mats):
        g = m.report["view_gmm"]
        colour = f"C{k % 10}"
        ax.plot(g["view_theta_deg"], g["rel_l2_per_theta"], marker="o", color=colour,
                label=f"{m.name} ({m.model}): fitted views")
        interp = g.get("interpolation") or {}
        for key, style in (("independent", "--"), ("coherent", ":")):
            if interp.get(key):
                ax.plot(interp["heldout_theta_deg"], interp[key], marker="x", linestyle=style,
                        color=colour, label=f"{m.name}: held-out views, {key} fit interpolated")
    ax.set_yscale("log")
    ax.set_xlabel("view elevation θ (degrees)")
    ax.set_ylabel("relative L2 error")
    ax.set_title("vMF mixture fit error per view (Töral19)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return fig


def visibility_figure(run: Run):
    """RMS error of the PCA-reconstructed SSDF against the number of PCA terms (Wang09 §5)."""
    objs = {name: rep.get("pca_error_vs_terms") for name, rep in run.visibility_objects.items()
            if rep.get("pca_error_vs_terms")}
    if not objs:
        return None
    fig = new_figure(6.0, 3.4)
    ax = fig.add_subplot()
    for name, curve in objs.items():
        terms = sorted(curve, key=int)
        ax.plot([int(t) for t in terms], [curve[t]["rms_rad"] for t in terms], marker="o",
                label=name)
    ax.set_xlabel("PCA terms")
    ax.set_ylabel("RMS SSDF error (radians)")
    ax.set_title("SSDF PCA reconstruction error (Wang09 §5)")
    ax.grid(True, alpha=0.3)
    ax.legend(title="object")
    fig.tight_layout()
    return fig


CHARTS = {
    "metrics": (metrics_figure, "display PSNR and LDR-ꟻLIP per method"),
    "timings": (timings_figure, "frame times"),
    "fit_views": (fit_views_figure, "vMF mixture fit error per view"),
    "visibility_pca": (visibility_figure, "SSDF PCA error vs terms"),
}


def write_charts(run: Run, root: Path) -> dict[str, Picture]:
    """Draw every chart the run has data for into `root/assets/plots/`; name → Picture."""
    out = {}
    for name, (make, caption) in CHARTS.items():
        with style():
            fig = make(run)
        if fig is None:
            continue
        href = f"{PLOTS}/{name}.png"
        path = save_png(fig, root / href)
        w, h = png_size(path)
        out[name] = Picture(path, href, caption, w, h)
    return out
