"""Pass/fail checks on metric dicts for CI: absolute thresholds, regressions against a
baseline, and JUnit XML (one testcase per method and check)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET


@dataclass(frozen=True)
class Threshold:
    """One `sgpipe compare` threshold option: metric `key` of `scope` ("frame"/"surface")."""

    name: str          # the CLI option's dest, e.g. "min_psnr" (--min-psnr)
    key: str
    scope: str
    bound: str         # "min": value >= limit passes; "max": value <= limit passes
    label: str
    unit: str = ""

    @property
    def option(self) -> str:
        return "--" + self.name.replace("_", "-")


THRESHOLDS = (
    Threshold("min_psnr", "display_psnr_db", "frame", "min", "display PSNR", " dB"),
    Threshold("max_flip", "flip_ldr", "frame", "max", "LDR-FLIP"),
    Threshold("max_hdr_flip", "flip_hdr", "frame", "max", "HDR-FLIP"),
    Threshold("max_relmse", "rel_mse", "frame", "max", "relMSE"),
    Threshold("min_ssim", "ssim", "frame", "min", "SSIM"),
    Threshold("min_surface_psnr", "display_psnr_db", "surface", "min", "surface display PSNR",
              " dB"),
    Threshold("max_surface_flip", "flip_ldr", "surface", "max", "surface LDR-FLIP"),
)


@dataclass
class Check:
    """One check's outcome: `method` (testcase class), `name` (testcase), failure message."""

    method: str
    name: str
    failure: str | None = None
    detail: str = ""

    @property
    def passed(self) -> bool:
        return self.failure is None


def _fmt(v, unit="") -> str:
    if v is None:
        return "undefined"
    if isinstance(v, float) and math.isinf(v):
        return "inf (identical)"
    return f"{v:.4g}{unit}"


def _value(metrics: dict, key: str, scope: str):
    d = metrics if scope == "frame" else metrics.get("surface")
    return None if d is None else d.get(key)


def threshold_checks(method: str, metrics: dict, limits: dict) -> list[Check]:
    """Checks of one method's metrics against the given limits ({Threshold.name: value})."""
    out = []
    for t in THRESHOLDS:
        limit = limits.get(t.name)
        if limit is None:
            continue
        v = _value(metrics, t.key, t.scope)
        name = f"{t.label} {'>=' if t.bound == 'min' else '<='} {limit:g}{t.unit}"
        c = Check(method, name, detail=f"{t.label} {_fmt(v, t.unit)}")
        if v is None:
            why = "no G-buffer for surface pixels" if t.scope == "surface" else "undefined"
            c.failure = f"{t.label} {why} ({t.option} {limit:g})"
        elif (v < limit) if t.bound == "min" else (v > limit):
            rel = "<" if t.bound == "min" else ">"
            c.failure = f"{t.label} {_fmt(v, t.unit)} {rel} {limit:g}{t.unit} ({t.option})"
        out.append(c)
    return out


def regression_checks(method: str, candidate: dict | None, baseline: dict, *,
                      psnr_drop_db: float, flip_rise: float) -> list[Check]:
    """Candidate vs baseline (each against its own reference): fail when display PSNR fell by
    more than `psnr_drop_db` or LDR-ꟻLIP rose by more than `flip_rise`."""
    p_name = f"display PSNR not below baseline by more than {psnr_drop_db:g} dB"
    f_name = f"LDR-FLIP not above baseline by more than {flip_rise:g}"
    if candidate is None:
        return [Check(method, n, failure=f"{method} missing from the candidate folder")
                for n in (p_name, f_name)]
    pc, pb = candidate["display_psnr_db"], baseline["display_psnr_db"]
    drop = 0.0 if pc == pb else pb - pc            # inf − inf is nan: equal means no drop
    p = Check(method, p_name, detail=f"display PSNR {_fmt(pc, ' dB')} vs baseline "
                                     f"{_fmt(pb, ' dB')}")
    if drop > psnr_drop_db:
        p.failure = (f"display PSNR {_fmt(pc, ' dB')} is {_fmt(drop, ' dB')} below the "
                     f"baseline's {_fmt(pb, ' dB')} (--max-psnr-drop {psnr_drop_db:g})")
    fc, fb = candidate["flip_ldr"], baseline["flip_ldr"]
    f = Check(method, f_name, detail=f"LDR-FLIP {_fmt(fc)} vs baseline {_fmt(fb)}")
    if fc - fb > flip_rise:
        f.failure = (f"LDR-FLIP {_fmt(fc)} is {_fmt(fc - fb)} above the baseline's "
                     f"{_fmt(fb)} (--max-flip-rise {flip_rise:g})")
    return [p, f]


def junit_xml(checks: list[Check], *, suite: str = "sgpipe compare") -> bytes:
    """JUnit XML: one <testcase classname=method name=check>, <failure> where it failed."""
    fails = sum(not c.passed for c in checks)
    root = ET.Element("testsuites", tests=str(len(checks)), failures=str(fails))
    ts = ET.SubElement(root, "testsuite", name=suite, tests=str(len(checks)),
                       failures=str(fails), errors="0", skipped="0")
    for c in checks:
        tc = ET.SubElement(ts, "testcase", classname=f"sgpipe.compare.{c.method}", name=c.name)
        if c.failure is not None:
            ET.SubElement(tc, "failure", message=c.failure, type="threshold").text = c.failure
        if c.detail:
            ET.SubElement(tc, "system-out").text = c.detail
    return ET.tostring(root, encoding="utf-8", xml_declaration=True) + b"\n"


def write_junit(path: str | Path, checks: list[Check]) -> Path:
    """Write `junit_xml(checks)` atomically."""
    from sgpipe.io.atomic import atomic_path
    path = Path(path)
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(junit_xml(checks))
    return path
