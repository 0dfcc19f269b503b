"""Fit-report plots drawn by matplotlib (Agg, no pyplot state): error-vs-lobes curves (Green06
Fig 5 style) and BRDF-slice vs fit panels, saved as deterministic PNGs (same data → same
bytes); `hemisphere_image` samples a function on the upper hemisphere for the panels."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

DPI = 100
#: PNG text chunks matplotlib would write (its version as Software); None drops them, so the
#: bytes depend on the data alone
PNG_METADATA = {"Software": None}
_RC = {"font.family": "DejaVu Sans", "font.size": 9, "axes.titlesize": 9,
       "axes.labelsize": 9, "legend.fontsize": 8, "svg.hashsalt": "sgpipe",
       "path.simplify": False}


def style():
    """The plots' matplotlib settings, as a context for building a figure and saving it."""
    import matplotlib
    return matplotlib.rc_context(_RC)


def new_figure(width_in: float, height_in: float, **kw):
    """A matplotlib Figure on the Agg canvas (thread-safe: no pyplot, no global figure list)."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    with matplotlib.rc_context(_RC):
        fig = Figure(figsize=(width_in, height_in), dpi=DPI, **kw)
    FigureCanvasAgg(fig)
    return fig


def save_png(fig, path: str | os.PathLike) -> Path:
    """Write `fig` as PNG atomically, without the Software / date text chunks."""
    from sgpipe.io.atomic import atomic_path
    import matplotlib
    path = Path(path)
    with matplotlib.rc_context(_RC), atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=DPI, metadata=PNG_METADATA)
    return path


def error_curves_figure(series: list[tuple[str, list, list]], *, title: str = ""):
    """Relative L2 error (log axis) against the lobe count, one labelled line per series
    (label, lobe counts, errors); non-positive / non-finite errors are left out."""
    import matplotlib
    with matplotlib.rc_context(_RC):
        fig = new_figure(5.6, 3.6)
        ax = fig.add_subplot()
        for label, xs, ys in series:
            xs, ys = np.asarray(xs, float), np.asarray(ys, float)
            ok = np.isfinite(ys) & (ys > 0)
            ax.plot(xs[ok], ys[ok], marker="o", markersize=4, linewidth=1.5, label=label)
        ax.set_yscale("log")
        ax.set_xlabel("lobes")
        ax.set_ylabel("relative L2 error")
        lobes = sorted({int(x) for _, xs, _ in series for x in xs})
        if lobes:
            ax.set_xticks(lobes)
        ax.grid(True, which="both", alpha=0.3)
        if series:
            ax.legend(loc="best")
        if title:
            ax.set_title(title)
        fig.tight_layout()
    return fig


def slice_panels_figure(rows: list[tuple[np.ndarray, np.ndarray]], labels: list[str]):
    """One row per view: the BRDF slice ρ(i,o)(n·i), its vMF-mixture fit (grey, black 0 to white
    = the slice's maximum) and |difference| (red, with its colour bar); images are orthographic views of the upper
    hemisphere of i (x right, y up, as `hemisphere_image` samples them)."""
    import matplotlib
    with matplotlib.rc_context(_RC):
        n = len(rows)
        height = 2.2 * n + 0.2
        fig = new_figure(7.6, height)
        # fixed margins instead of tight_layout (which measures every tick label: slow)
        fig.subplots_adjust(left=0.08, right=0.9, bottom=0.55 / height, top=1 - 0.5 / height,
                            wspace=0.35, hspace=0.75)
        axes = fig.subplots(n, 3, squeeze=False)
        titles = ("BRDF × cos slice", "vMF mixture fit", "|slice − fit|")
        for r, ((f, g), label) in enumerate(zip(rows, labels)):
            s = 1.0 / max(float(np.max(f)), 1e-300)
            panels = (f * s, g * s, np.abs(f - g) * s)
            for c, (ax, img) in enumerate(zip(axes[r], panels)):
                im = ax.imshow(img, cmap="Reds" if c == 2 else "gray", vmin=0.0,
                               vmax=1.0 if c < 2 else max(float(img.max()), 1e-12),
                               extent=(-1, 1, -1, 1), origin="upper",
                               interpolation="nearest")
                ax.set_title(f"{label}\n{titles[c]}" if c == 0 else f"\n{titles[c]}")
                ax.set_xlabel("x (tangent)")
                if c == 0:
                    ax.set_ylabel("y (bitangent)")
                ax.set_xticks([-1, 0, 1])
                ax.set_yticks([-1, 0, 1])
            # the grey panels share 0 … 1 (the slice's maximum); the difference its own scale
            fig.colorbar(im, ax=axes[r, 2], fraction=0.046, pad=0.04,
                         label="relative to the slice's max")
    return fig


def hemisphere_image(fn, res: int = 96) -> np.ndarray:
    """Orthographic view of the upper hemisphere: pixel (x, y) in the unit disk ↦ direction
    (x, −y, √(1 − x² − y²)); fn maps (N,3) -> (N,). Outside the disk: 0."""
    c = (np.arange(res) + 0.5) / res * 2.0 - 1.0
    x, y = np.meshgrid(c, -c)
    r2 = x * x + y * y
    inside = r2 < 1.0
    d = np.stack([x, y, np.sqrt(np.maximum(0.0, 1.0 - r2))], -1)[inside]
    out = np.zeros((res, res))
    out[inside] = fn(d)
    return out
