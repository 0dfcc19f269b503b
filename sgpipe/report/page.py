"""Render the report page: jinja2 templates shipped in sgpipe/report/templates/ (read through
importlib.resources), the metrics table with each column's best value marked, display sizes
that scale small renders by whole pixels."""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources

import sgpipe
from sgpipe.report.collect import KNOWN_STAGES, STAGE_COMMAND, Picture, Run

TEMPLATE = "index.html.j2"


@dataclass(frozen=True)
class Column:
    label: str
    key: str            # metrics key; "surface." prefix: the surface-pixel variant
    spec: str           # format spec
    better: str         # "high" / "low": which value is marked best
    unit: str = ""


#: the metrics table, from report.compare[method] (sgpipe.stages.compare) and timings.json
METRIC_COLUMNS = (
    Column("display PSNR (dB)", "display_psnr_db", ".2f", "high"),
    Column("surfaces", "surface.display_psnr_db", ".2f", "high"),
    Column("LDR-ꟻLIP", "flip_ldr", ".4f", "low"),
    Column("surfaces", "surface.flip_ldr", ".4f", "low"),
    Column("HDR-ꟻLIP", "flip_hdr", ".4f", "low"),
    Column("relMSE", "rel_mse", ".4g", "low"),
    Column("surfaces", "surface.rel_mse", ".4g", "low"),
    Column("linear PSNR (dB)", "psnr_db", ".2f", "high"),
    Column("SSIM", "ssim", ".4f", "high"),
    Column("ms / frame", "time.ms", ".3g", "low"),
)
_PSNR_KEYS = {"display_psnr_db", "psnr_db"}     # None there means the images are identical


def fmt(value, spec: str = "g", unit: str = "") -> str:
    """A number for the page; '—' for none."""
    if value is None:
        return "—"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(fmt(v, spec) for v in value) + "]" + unit
    try:
        return format(value, spec) + unit
    except (TypeError, ValueError):
        return str(value) + unit


def size(p: Picture, target: int = 0) -> tuple[int, int]:
    """Display size: a picture narrower than `target` is enlarged by a whole factor (crisp
    pixels); otherwise its own size (CSS max-width keeps it inside the page)."""
    k = max(1, target // p.width) if target and p.width < target else 1
    return p.width * k, p.height * k


def _value(row, key: str):
    if key == "time.ms":
        return None if row.seconds is None else 1e3 * row.seconds
    d = row.metrics or {}
    if key.startswith("surface."):
        d, key = d.get("surface") or {}, key.split(".", 1)[1]
    v = d.get(key)
    if v is None and key in _PSNR_KEYS and row.metrics and row.metrics.get("identical"):
        return math.inf
    return v


def metric_rows(run: Run) -> list[dict]:
    """Rows of the metrics table: text per cell and whether it is the column's best."""
    rows = [r for r in run.methods if r.metrics]
    values = [[_value(r, c.key) for c in METRIC_COLUMNS] for r in rows]
    best = []
    for j, c in enumerate(METRIC_COLUMNS):
        col = [v[j] for v in values if isinstance(v[j], (int, float))]
        best.append((max(col) if c.better == "high" else min(col)) if len(col) > 1 else None)
    out = []
    for r, vals in zip(rows, values):
        cells = []
        for j, (c, v) in enumerate(zip(METRIC_COLUMNS, vals)):
            text = "∞ (identical)" if v == math.inf else fmt(v, c.spec, c.unit)
            cells.append({"text": text, "best": best[j] is not None and v == best[j]})
        out.append({"method": r.method, "cells": cells})
    return out


def timing_rows(run: Run) -> list[tuple[str, str]]:
    st = run.stages.get("render")
    if st is None:
        return []
    return [(k, fmt(v, ".4g", " /s" if k.endswith("_fps") else " s"))
            for k, v in sorted(st.timings.items())]


def envmap_facts(run: Run) -> list[tuple[str, str]]:
    st = run.stages.get("envmap")
    if st is None:
        return []
    rep, params = st.report, st.manifest.get("params") or {}
    facts = [("environment", params.get("environment")),
             ("cube resolution", params.get("cube_resolution")),
             ("pyramid levels", rep.get("pyramid_levels")),
             ("pyramid λ₀", fmt(rep.get("pyramid_lambda0"), "g")),
             ("SG light irradiance relative error (RGB)",
              fmt(rep.get("sg_light_irradiance_rel_err"), ".4f")),
             ("SH irradiance relative error (RGB)", fmt(rep.get("sh_irradiance_rel_err"), ".4f"))]
    return [(k, "—" if v is None else v) for k, v in facts]


def _template(name: str) -> str:
    return resources.files("sgpipe.report").joinpath("templates", name).read_text("utf-8")


def environment():
    """The jinja2 environment: templates from the package, HTML autoescaping, strict
    undefined names (a template typo fails loudly instead of printing nothing)."""
    import jinja2
    env = jinja2.Environment(
        loader=jinja2.FunctionLoader(lambda name: (_template(name), None, lambda: True)),
        autoescape=True, undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    env.globals.update(fmt=fmt, size=size)
    return env


def render_page(run: Run, charts: dict[str, Picture]) -> str:
    """The report's index.html text (depends on the run folder's content only)."""
    stage_rows = list(KNOWN_STAGES) + [s for s in run.stages if s not in KNOWN_STAGES]
    version = next((s.manifest.get("sgpipe_version") for s in run.stages.values()),
                   sgpipe.__version__)
    return environment().get_template(TEMPLATE).render(
        run=run, run_name=run.root.resolve().name, version=version, charts=charts,
        facts=run.render_facts, commands=STAGE_COMMAND, stage_rows=stage_rows,
        metric_columns=METRIC_COLUMNS, metric_rows=metric_rows(run),
        timing_rows=timing_rows(run), envmap_facts=envmap_facts(run))
