"""`sgpipe compare`: image metrics against a reference (sgpipe.metrics) and CI gating.

Entry points:
  * `compare_cli(...)` — the CLI command. Two EXRs: IMAGE against REFERENCE. One render folder:
    every method against the folder's truth (`render.compare_to` of its manifest, else
    `reference`). Two render folders: each against its own truth, the first (candidate)
    checked against the second (baseline) for regressions. Prints a table (or JSON), checks
    the thresholds (sgpipe.metrics.gates), writes JUnit XML and a difference PNG on request;
    returns the failed checks (the CLI exits 1 when there are any).
  * `compare_to_reference(run, image, reference, name, ...)` — used by the render stage: writes
    `<name>.diff.png` into the stage's staging folder and stores the metrics under
    `run.report["compare"][name]`.
Display metrics use the folder's `render.preview_exposure` (from its manifest) unless
--exposure is given. Surface metrics need the G-buffer's object ids: a render folder's
`gbuffer.npz`, the one beside IMAGE, or --gbuffer. Bad inputs (missing/unreadable EXR,
NaN/Inf, size mismatch, a folder without a truth image) are BadInput (exit 2).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from sgpipe.artifacts.render import GBUFFER, image_name
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz, write_png
from sgpipe import metrics
from sgpipe.metrics import gates

def load_pair(image: str | Path, reference: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read both EXRs (1, 3 or 4 channels); a size mismatch is BadInput naming the image."""
    a = read_exr(image, channels=(1, 3, 4), key="image")
    r = read_exr(reference, channels=(1, 3, 4), key="reference")
    if a.shape[:2] != r.shape[:2]:
        raise BadInput(f"size {a.shape[1]}x{a.shape[0]} differs from the reference's "
                       f"{r.shape[1]}x{r.shape[0]} ({reference})", file=image, key="image")
    return a, r


def compare_arrays(image: np.ndarray, reference: np.ndarray, *, diff_png: str | Path | None = None,
                   peak: float | str = metrics.PSNR_PEAK, mask=None, exposure: float = 0.0,
                   surface=None) -> dict:
    """Metrics dict (see metrics.compare_images) plus the difference-PNG scale when written."""
    if np.asarray(image).shape[:2] != np.asarray(reference).shape[:2]:
        raise BadInput(f"image size {np.shape(image)[:2]} differs from reference size "
                       f"{np.shape(reference)[:2]}", key="image")
    out = metrics.compare_images(image, reference, peak=peak, mask=mask, exposure=exposure,
                                 surface=surface)
    if diff_png is not None:
        scale = metrics.difference_scale(image, reference)
        write_png(diff_png, metrics.false_color_difference(image, reference, scale=scale),
                  already_8bit=True)
        out["diff_png"] = str(diff_png)
        out["diff_scale"] = scale
    return out


def _manifest_render(folder: Path) -> dict:
    """A render folder's `params.render` from its manifest ({} when there is none)."""
    f = folder / "manifest.json"
    if not f.is_file():
        return {}
    try:
        return json.loads(f.read_text()).get("params", {}).get("render", {}) or {}
    except (OSError, ValueError) as e:
        raise BadInput(f"unreadable manifest ({e})", file=f, key="render") from None


def surface_from_gbuffer(path: str | Path, shape) -> np.ndarray:
    """Surface mask (metrics.surface_mask) from a `gbuffer.npz` or a folder holding one."""
    path = Path(path)
    f = path / GBUFFER if path.is_dir() else path
    ids = read_npz(f, key="gbuffer", required=("object_id",))["object_id"]
    if np.shape(ids) != tuple(shape[:2]):
        raise BadInput(f"object_id is {np.shape(ids)[1]}x{np.shape(ids)[0]} but the images "
                       f"are {shape[1]}x{shape[0]}", file=f, key="gbuffer")
    return metrics.surface_mask(ids)


def compare_files(image: str | Path, reference: str | Path, *,
                  diff_png: str | Path | None = None, peak: float | str = metrics.PSNR_PEAK,
                  exposure: float | None = None, gbuffer: str | Path | None = None) -> dict:
    """Read two EXRs and compare them (see compare_arrays). Exposure and G-buffer default to
    the render folder IMAGE lies in (its manifest's preview exposure, its gbuffer.npz)."""
    image, reference = Path(image), Path(reference)
    a, r = load_pair(image, reference)
    if exposure is None:
        exposure = float(_manifest_render(image.parent).get("preview_exposure", 0.0))
    if gbuffer is None and (image.parent / GBUFFER).is_file():
        gbuffer = image.parent / GBUFFER
    surface = None if gbuffer is None else surface_from_gbuffer(gbuffer, a.shape)
    out = compare_arrays(a, r, diff_png=diff_png, peak=peak, exposure=exposure,
                         surface=surface)
    out.update(image=str(image), reference=str(reference), width=int(a.shape[1]),
               height=int(a.shape[0]))
    if gbuffer is not None:
        out["gbuffer"] = str(gbuffer)
    return out


def compare_folder(folder: str | Path, *, truth: str | None = None, methods=None,
                   exposure: float | None = None) -> dict:
    """Every method of a render folder against its truth: {"truth", "exposure", "methods":
    {method: metrics}}. Methods default to the manifest's list, else every `<m>.exr`."""
    folder = Path(folder)
    params = _manifest_render(folder)
    truth = truth or params.get("compare_to") or "reference"
    ref_path = folder / image_name(truth)
    if not ref_path.is_file():
        raise BadInput(f"no {image_name(truth)} to compare against (pick one with --truth)",
                       file=folder, key="truth")
    found = params.get("methods") or sorted(p.name[:-4] for p in folder.glob("*.exr"))
    chosen = [m for m in (methods or found) if m != truth]
    if exposure is None:
        exposure = float(params.get("preview_exposure", 0.0))
    gb = folder / GBUFFER if (folder / GBUFFER).is_file() else None
    out = {}
    for m in chosen:
        if not (folder / image_name(m)).is_file():
            if methods:
                raise BadInput(f"no {image_name(m)} here", file=folder, key="method")
            continue
        out[m] = compare_files(folder / image_name(m), ref_path, exposure=exposure, gbuffer=gb)
    return {"folder": str(folder), "truth": truth, "exposure": exposure, "methods": out}


def _json_safe(d):
    """inf/nan are not JSON: PSNR of identical images is written as null with identical=true."""
    if isinstance(d, dict):
        out = {k: _json_safe(v) for k, v in d.items()}
        if "mse" in d:
            out["identical"] = d["mse"] == 0.0
        return out
    if isinstance(d, list):
        return [_json_safe(v) for v in d]
    return None if isinstance(d, float) and not math.isfinite(d) else d


def _db(v) -> str:
    return "inf (identical)" if v is not None and math.isinf(v) else f"{v:.2f} dB"


def _num(v, fmt=".4f") -> str:
    return "undefined" if v is None else format(v, fmt)


def format_table(d: dict) -> str:
    """Human-readable table of a compare_files result."""
    s = d.get("surface")
    surf = (lambda k, f: f"   surfaces: {f(s[k])}") if s else (lambda k, f: "")
    rows = [
        ("image", d.get("image", "")),
        ("reference", d.get("reference", "")),
        ("size", f"{d.get('width', '?')}x{d.get('height', '?')}"),
        ("display PSNR", _db(d["display_psnr_db"]) + surf("display_psnr_db", _db)
         + f"   [8-bit sRGB preview at exposure {d['exposure']:g}]"),
        ("LDR-FLIP", _num(d["flip_ldr"]) + surf("flip_ldr", _num) + "   [display image]"),
        ("HDR-FLIP", _num(d["flip_hdr"]) + surf("flip_hdr", _num) + "   [linear radiance]"),
        ("relMSE", f"{d['rel_mse']:.4e}" + surf("rel_mse", lambda v: f"{v:.4e}")
         + "   [(x-r)²/(r²+0.01), linear]"),
        ("linear PSNR", _db(d["psnr_db"]) + surf("psnr_db", _db)
         + f"   [linear RGB, peak {d['peak']:g}]"),
        ("SSIM", f"{d['ssim']:.5f}" + surf("ssim", lambda v: f"{v:.5f}")
         + "   [luminance, Gaussian σ=1.5]"),
        ("max |x-r|", f"{d['max_abs_error']:.4g}"),
    ]
    if s:
        rows.append(("surfaces", f"{s['pixels']} pixels whose 3x3 neighbourhood is one object"
                                 f" ({d.get('gbuffer', 'G-buffer')})"))
    if "diff_png" in d:
        rows.append(("diff PNG", f"{d['diff_png']}   [±{d['diff_scale']:.3g} luminance "
                                 "= full colour; red: brighter, blue: darker]"))
    w = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{w}}  {v}" for k, v in rows)


_COLS = (("display PSNR", "display_psnr_db", _db), ("LDR-FLIP", "flip_ldr", _num),
         ("HDR-FLIP", "flip_hdr", _num), ("relMSE", "rel_mse", lambda v: f"{v:.3e}"),
         ("linear PSNR", "psnr_db", _db), ("SSIM", "ssim", lambda v: f"{v:.4f}"))


def format_folder_table(res: dict, label: str = "") -> str:
    """One row per method (and per method's surfaces) of a compare_folder result."""
    rows = [("method", *(c for c, _, _ in _COLS))]
    for m, d in res["methods"].items():
        rows.append((m, *(f(d[k]) for _, k, f in _COLS)))
        if d.get("surface"):
            rows.append((f"  {m} surfaces", *(f(d["surface"][k]) for _, k, f in _COLS)))
    w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    head = (f"{label}{res['folder']}: against {res['truth']}, display at exposure "
            f"{res['exposure']:g}")
    return "\n".join([head] + ["  ".join(c.ljust(w[i]) for i, c in enumerate(r)).rstrip()
                                for r in rows])


def compare_cli(image, reference=None, *, as_json: bool = False, diff_png=None,
                exposure: float | None = None, gbuffer=None, truth: str | None = None,
                methods=None, limits: dict | None = None, psnr_drop_db: float = 0.1,
                flip_rise: float = 0.002, junit=None) -> list:
    """The `sgpipe compare` command body (module docstring): returns the failed checks."""
    image, reference = Path(image), None if reference is None else Path(reference)
    limits = limits or {}
    checks: list[gates.Check] = []
    if image.is_dir():
        if reference is not None and not reference.is_dir():
            raise BadInput("a render folder compares with another render folder, not a file",
                           file=reference, key="reference")
        if diff_png is not None or gbuffer is not None:
            raise BadInput("--diff and --gbuffer are for two images (a folder has its own "
                           "G-buffer and diff PNGs)", file=image, key="image")
        cand = compare_folder(image, truth=truth, methods=methods, exposure=exposure)
        base = None if reference is None else compare_folder(reference, truth=truth,
                                                             methods=methods,
                                                             exposure=exposure)
        for m, d in cand["methods"].items():
            checks += [gates.Check(m, "compared", detail=f"display PSNR "
                                   f"{_db(d['display_psnr_db'])}, LDR-FLIP "
                                   f"{_num(d['flip_ldr'])}")]
            checks += gates.threshold_checks(m, d, limits)
        for m, d in (base or {"methods": {}})["methods"].items():
            checks += gates.regression_checks(m, cand["methods"].get(m), d,
                                              psnr_drop_db=psnr_drop_db, flip_rise=flip_rise)
        result = cand if base is None else {"candidate": cand, "baseline": base}
        text = format_folder_table(cand, "" if base is None else "candidate ")
        if base is not None:
            text += "\n" + format_folder_table(base, "baseline  ")
    else:
        if reference is None:
            raise BadInput("IMAGE is a file: give the REFERENCE image too", file=image,
                           key="reference")
        result = compare_files(image, reference, diff_png=diff_png, exposure=exposure,
                               gbuffer=gbuffer)
        checks = [gates.Check(image.stem, "compared")] + gates.threshold_checks(
            image.stem, result, limits)
        text = format_table(result)
    failed = [c for c in checks if not c.passed]
    if as_json:
        out = _json_safe(result)
        out["checks"] = [{"method": c.method, "check": c.name, "passed": c.passed,
                          **({"failure": c.failure} if c.failure else {})} for c in checks]
        sys.stdout.write(json.dumps(out, indent=2, sort_keys=True) + "\n")
    else:
        sys.stdout.write(text + "\n")
    sys.stdout.flush()
    if junit is not None:
        gates.write_junit(junit, checks)
    for c in failed:
        sys.stderr.write(f"sgpipe compare: FAIL {c.method}: {c.failure}\n")
    return failed


def compare_to_reference(run, image: np.ndarray, reference, name: str, *,
                         exposure: float = 0.0, surface=None) -> dict:
    """Render-stage hook: metrics of `image` against `reference` (an array, e.g. this run's
    `reference` method, or an EXR path), display metrics at `exposure`, surface variants over
    the `surface` mask (metrics.surface_mask of the G-buffer's object ids) when given.

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
    d = compare_arrays(image, ref, diff_png=run.path(image_name(name, "diff.png")),
                       exposure=exposure, surface=surface)
    d["diff_png"] = f"{name}.diff.png"
    d["reference"] = label
    safe = _json_safe(d)
    run.report.setdefault("compare", {})[name] = safe
    return safe
