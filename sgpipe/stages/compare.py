"""`sgpipe compare A.exr B.exr`: image metrics against a reference (sgpipe.metrics).

Two entry points:
  * `compare_cli(image, reference, as_json=False, diff_png=None)` — the CLI command: prints a
    table (or JSON) of PSNR / SSIM / relative MSE; writes a false-colour difference PNG.
  * `compare_to_reference(run, image, reference, name)` — used by the render stage after
    rendering when `render.compare_to` names a method (reference = that image, or an EXR
    path): writes `<name>.diff.png` into the stage's staging folder and returns the metrics
    (also stored under `run.report["compare"][name]`).
Bad inputs (missing/unreadable EXR, NaN/Inf, size mismatch) are BadInput (exit 2).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from sgpipe.artifacts.render import image_name
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, write_png
from sgpipe import metrics


def load_pair(image: str | Path, reference: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read both EXRs (1, 3 or 4 channels); a size mismatch is BadInput naming the image."""
    a = read_exr(image, channels=(1, 3, 4), key="image")
    r = read_exr(reference, channels=(1, 3, 4), key="reference")
    if a.shape[:2] != r.shape[:2]:
        raise BadInput(f"size {a.shape[1]}x{a.shape[0]} differs from the reference's "
                       f"{r.shape[1]}x{r.shape[0]} ({reference})", file=image, key="image")
    return a, r


def compare_arrays(image: np.ndarray, reference: np.ndarray, *, diff_png: str | Path | None = None,
                   peak: float | str = metrics.PSNR_PEAK, mask=None) -> dict:
    """Metrics dict (see metrics.compare_images) plus the difference-PNG scale when written."""
    if np.asarray(image).shape[:2] != np.asarray(reference).shape[:2]:
        raise BadInput(f"image size {np.shape(image)[:2]} differs from reference size "
                       f"{np.shape(reference)[:2]}", key="image")
    out = metrics.compare_images(image, reference, peak=peak, mask=mask)
    if diff_png is not None:
        scale = metrics.difference_scale(image, reference)
        write_png(diff_png, metrics.false_color_difference(image, reference, scale=scale),
                  already_8bit=True)
        out["diff_png"] = str(diff_png)
        out["diff_scale"] = scale
    return out


def compare_files(image: str | Path, reference: str | Path, *,
                  diff_png: str | Path | None = None,
                  peak: float | str = metrics.PSNR_PEAK) -> dict:
    """Read two EXRs and compare them (see compare_arrays)."""
    a, r = load_pair(image, reference)
    out = compare_arrays(a, r, diff_png=diff_png, peak=peak)
    out.update(image=str(image), reference=str(reference), width=int(a.shape[1]),
               height=int(a.shape[0]))
    return out


def _json_safe(d: dict) -> dict:
    """inf/nan are not JSON: PSNR of identical images is written as null with identical=true."""
    out = {}
    for k, v in d.items():
        out[k] = None if isinstance(v, float) and not math.isfinite(v) else v
    out["identical"] = d.get("mse") == 0.0
    return out


def format_table(d: dict) -> str:
    """Human-readable table of a compare_files result."""
    psnr = d["psnr_db"]
    rows = [
        ("image", d.get("image", "")),
        ("reference", d.get("reference", "")),
        ("size", f"{d.get('width', '?')}x{d.get('height', '?')}"),
        ("PSNR", ("inf (identical)" if math.isinf(psnr) else f"{psnr:.3f} dB")
         + f"   [linear RGB, peak {d['peak']:g}]"),
        ("SSIM", f"{d['ssim']:.5f}   [luminance, Gaussian σ=1.5]"),
        ("relMSE", f"{d['rel_mse']:.4e}   [(x-r)²/(r²+0.01)]"),
        ("MSE", f"{d['mse']:.4e}"),
        ("max |x-r|", f"{d['max_abs_error']:.4g}"),
    ]
    if "diff_png" in d:
        rows.append(("diff PNG", f"{d['diff_png']}   [±{d['diff_scale']:.3g} luminance "
                                 "= full colour; red: brighter, blue: darker]"))
    w = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{w}}  {v}" for k, v in rows)


def compare_cli(image, reference, *, as_json: bool = False, diff_png=None) -> dict:
    """The `sgpipe compare` command body: print a table (or JSON) and return the metrics."""
    d = compare_files(Path(image), Path(reference), diff_png=diff_png)
    if as_json:
        sys.stdout.write(json.dumps(_json_safe(d), indent=2, sort_keys=True) + "\n")
    else:
        sys.stdout.write(format_table(d) + "\n")
    sys.stdout.flush()
    return d


def compare_to_reference(run, image: np.ndarray, reference, name: str) -> dict:
    """Render-stage hook: metrics of `image` against `reference` (an array, e.g. this run's
    `reference` method, or an EXR path).

    Writes `<name>.diff.png` into the StageRun's staging folder and stores the metrics in
    `run.report["compare"][name]` (JSON-safe: PSNR of identical images is null).
    """
    if isinstance(reference, (str, Path)):
        ref = read_exr(reference, channels=(1, 3, 4), key="render.compare_to")
        # this stage's own output: record its final name, not the staging path
        staged = Path(reference).parent == run.staging
        label = Path(reference).name if staged else str(reference)
    else:
        ref, label = np.asarray(reference), "array"
    if np.shape(image)[:2] != ref.shape[:2]:
        raise BadInput(f"rendered image is {np.shape(image)[1]}x{np.shape(image)[0]} but the "
                       f"reference is {ref.shape[1]}x{ref.shape[0]}", file=label,
                       key="render.compare_to")
    d = compare_arrays(image, ref, diff_png=run.path(image_name(name, "diff.png")))
    d["diff_png"] = f"{name}.diff.png"
    d["reference"] = label
    safe = _json_safe(d)
    run.report.setdefault("compare", {})[name] = safe
    return safe
