"""Fidelity measurement shared by the corpus runner and bench_fidelity: a scene through the real
stages (fit → precompute → render) against a two-seed Monte Carlo reference, display PSNR
corrected for the reference's noise, LDR-ꟻLIP and linear relMSE beside it."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import tempfile
from contextlib import ExitStack, redirect_stderr, redirect_stdout
from io import StringIO
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
SUPERSAMPLE = 3
REFERENCE_SPP = 256          # per seed; the truth is the mean of two seeds
#: fit-stage reports the renders do not read (error-vs-lobes curves, held-out views): skipped
QUICK_FIT = ("fit.ndf_sg.report_lobes=0", "fit.view_gmm.report_lobes=0",
             "fit.view_gmm.holdout=false")
METHODS = ("sg", "gmm", "fis")


def load_scene(scene, overrides=()):
    """A validated root Config from a YAML path or a raw config dict (paths in a dict resolve
    against the repository root), after `key.path=value` overrides."""
    from sgpipe.config.loader import apply_override, load_config
    if isinstance(scene, (str, Path)):
        return load_config(Path(scene), list(overrides))
    from sgpipe.config.root import Config
    from sgpipe.config.schema import Context, build
    raw = copy.deepcopy(scene)
    for ov in overrides:
        apply_override(raw, ov, None)
    return build(Config, raw, (), Context(file=ROOT / "<dict>", lines={}))


def surface_of(cfg) -> np.ndarray:
    """The camera's surface pixels (sgpipe.metrics.surface_mask of the pixel-centre hits)."""
    from sgpipe.metrics import surface_mask
    from sgpipe.render.scene import load_trace_objects
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import Tracer
    cam = Camera.from_spec(cfg.render.camera)
    return surface_mask(Tracer(load_trace_objects(cfg)).trace(*cam.rays()).object_id)


def render_reference(cfg, spp: int = REFERENCE_SPP) -> dict:
    """The reference (box pixel filter unless the config says otherwise) at `spp` with seeds
    cfg.seed and cfg.seed + 1: their mean is the truth; seed A vs seed B measures its noise."""
    from sgpipe.metrics import display_psnr
    from sgpipe.stages.render import reference_from_config
    rs = dataclasses.replace(cfg.render, spp=spp)
    runs = [reference_from_config(dataclasses.replace(cfg, render=rs, seed=cfg.seed + k))
            for k in (0, 1)]
    surface = surface_of(cfg)
    a, b = (r.image.astype(np.float64) for r in runs)
    exp = cfg.render.preview_exposure
    return {"image": 0.5 * (a + b), "seeds": (a, b), "spp": 2 * spp, "surface": surface,
            "exposure": exp, "seconds": sum(r.seconds for r in runs),
            "seed_psnr_db": display_psnr(a, b, exposure=exp),
            "seed_surface_psnr_db": display_psnr(a, b, exposure=exp, mask=surface)}


def _db(mse: float) -> float:
    return math.inf if mse <= 0 else 10.0 * math.log10(255.0 ** 2 / mse)


def display_errors(image, ref: dict, mask=None) -> dict:
    """Display PSNR (8-bit preview, sgpipe.metrics.display) of `image` against the mean of the
    two reference seeds A, B, raw and noise-corrected: E|m − (A+B)/2|² = |m − truth|² + σ²/2
    and E|A − B|² = 2σ², so |m − truth|² ≈ MSE(m, mean) − MSE(A, B)/4. `floor_db`: the mean's
    own noise, 10 log10(255² / (MSE(A, B)/4))."""
    from sgpipe.metrics import display_image
    exp = ref["exposure"]
    d = [display_image(x, exposure=exp).astype(np.float64)
         for x in (image, ref["seeds"][0], ref["seeds"][1])]
    sel = (lambda x: x) if mask is None else (lambda x: x[np.asarray(mask, bool)])
    m = sel(d[0])
    mean = 0.5 * (sel(d[1]) + sel(d[2]))
    raw = float(np.mean((m - mean) ** 2))
    noise = float(np.mean((sel(d[1]) - sel(d[2])) ** 2)) / 4.0
    return {"raw_db": _db(raw), "db": _db(raw - noise), "floor_db": _db(noise)}


def run_stage(name: str, cfg, out: Path) -> None:
    import importlib
    importlib.import_module(f"sgpipe.stages.{name}").run(cfg, out)


def _render_methods(cfg, methods, out: Path) -> tuple[dict, dict]:
    """({method: (image, seconds per frame)}, {method: error}) through fit → precompute →
    render; if the joint render fails, each method alone, so one broken method names itself."""
    from sgpipe.artifacts.render import read_image
    from sgpipe.errors import BadInput

    def why(e):
        msg = e.one_line() if isinstance(e, BadInput) else str(e)
        return f"{type(e).__name__}: {(msg.splitlines() or [''])[0][:160]}"

    def render(ms):
        rs = dataclasses.replace(cfg.render, methods=list(ms), supersample=SUPERSAMPLE,
                                 timing_repeats=1, compare_to=None)
        run_stage("render", dataclasses.replace(cfg, render=rs), out)
        t = json.loads((out / "render" / "timings.json").read_text())
        return {m: (read_image(out / "render", m), float(t.get(f"{m}_s", math.nan)))
                for m in ms}

    # the upstream stages see the methods measured (the fit writes gmm_toral19's own mixtures)
    up = dataclasses.replace(cfg, render=dataclasses.replace(cfg.render, methods=list(methods)))
    try:
        for s in ("fit", "precompute"):
            run_stage(s, up, out)
    except Exception as e:  # noqa: BLE001 - reported, never hidden
        return {}, {m: why(e) for m in methods}
    try:
        return render(methods), {}
    except Exception:  # noqa: BLE001 - retried per method below
        pass
    images, errors = {}, {}
    for m in methods:
        try:
            images.update(render([m]))
        except Exception as e:  # noqa: BLE001
            errors[m] = why(e)
    return images, errors


def measure(scene, methods=METHODS, overrides=(), *, spp: int = REFERENCE_SPP,
            reference: dict | None = None, out: Path | None = None,
            quiet: bool = False) -> dict:
    """One scene → {"name", "reference": render_reference(...) dict, "methods": {method:
    {display_psnr_db, surface_display_psnr_db, flip_ldr, surface_flip_ldr, rel_mse,
    surface_rel_mse, ms, image}}, "errors": {method: reason}}. `reference`: a previous result's
    "reference" to reuse (same camera and scene); `out`: keep the stage folders there (else a
    temporary folder); `quiet`: the stages' log lines are swallowed."""
    from sgpipe.metrics import compare_images
    cfg = load_scene(scene, QUICK_FIT + tuple(overrides))
    with ExitStack() as stack:
        if quiet:
            hush = stack.enter_context(StringIO())
            stack.enter_context(redirect_stdout(hush))
            stack.enter_context(redirect_stderr(hush))
        ref = reference if reference is not None else render_reference(cfg, spp)
        with tempfile.TemporaryDirectory(prefix="sgpipe-bench-fid-") as tmp:
            images, errors = _render_methods(cfg, list(methods),
                                             Path(out) if out else Path(tmp))
    res = {}
    for m, (img, sec) in images.items():
        c = compare_images(img, ref["image"], exposure=ref["exposure"], surface=ref["surface"])
        whole, surf = display_errors(img, ref), display_errors(img, ref, ref["surface"])
        res[m] = {"display_psnr_db": whole["db"], "surface_display_psnr_db": surf["db"],
                  "raw_display_psnr_db": whole["raw_db"],
                  "raw_surface_display_psnr_db": surf["raw_db"],
                  "floor_db": whole["floor_db"], "surface_floor_db": surf["floor_db"],
                  "flip_ldr": c["flip_ldr"], "surface_flip_ldr": c["surface"]["flip_ldr"],
                  "rel_mse": c["rel_mse"], "surface_rel_mse": c["surface"]["rel_mse"],
                  "ms": 1e3 * sec, "image": img}
    return {"name": cfg.name, "reference": ref, "methods": res, "errors": errors}


def noisy(v: dict, scope: str = "surface_") -> bool:
    """The reference's noise within 3 dB of the method's raw error: the corrected PSNR is then
    conservative but uncertain (tests/test_bench_fidelity.py)."""
    return v[f"{scope}floor_db"] - v[f"raw_{scope}display_psnr_db"] < 3.0
