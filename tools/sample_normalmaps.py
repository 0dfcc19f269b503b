"""The high-frequency sample normal map of Han07 (issue 16): V-grooves and spherical bumps.

    .venv/bin/python tools/sample_normalmaps.py [--out DIR]     (make samples calls `make`)

A 256² tile of 4 × 4 cells. Cells alternate (checkerboard) between V-grooves running along v
(normals tilted ±x) and along u (tilted ±y), 8 texels per groove period, slope GROOVE_SLOPE;
each cell holds one spherical cap (footprint radius CAP_RADIUS cells, rim tilt CAP_RIM_DEG)
whose normals sweep every direction up to the rim. Texel centres never fall on a groove's kink,
so every texel is one exact normal. Only +, −, ×, ÷ and √ touch texel values (correctly rounded,
tools/canonical.py), so the encoded integers are the same on every CPU (exact ties, the zero
components at 0.5 · 65535, round half to even everywhere).

Files: grooves_normal.png (16-bit RGB), grooves_normal_8bit.png (8-bit RGB), both storing
(n + 1)/2 with row 0 the top of the image (v = 1), +x along u, +y along v (CONVENTIONS).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from canonical import normalize3  # noqa: E402

SIZE = 256
CELLS = 4
GROOVE_PERIOD = 8            # texels
GROOVE_SLOPE = 0.75          # |dh/dx|: normals tilted atan(0.75) = 36.9°
CAP_RADIUS = 0.3             # footprint radius in cells
CAP_RIM_SIN = 0.8            # sin of the rim tilt (53.1°)
FILES = ("grooves_normal.png", "grooves_normal_8bit.png")


def grooves_normals(size: int = SIZE) -> np.ndarray:
    """Unit tangent-space normals (size, size, 3), row 0 = top of the image."""
    rows, cols = np.meshgrid(np.arange(size), np.arange(size), indexing="ij")
    cell = size // CELLS
    # height h(x) = slope · triangle wave: the sign of the slope flips every half period
    phase_x = (cols % GROOVE_PERIOD) < GROOVE_PERIOD // 2
    phase_y = (rows % GROOVE_PERIOD) < GROOVE_PERIOD // 2
    along_v = ((rows // cell + cols // cell) % 2) == 0    # grooves run along v: tilt in x
    gx = np.where(along_v, np.where(phase_x, GROOVE_SLOPE, -GROOVE_SLOPE), 0.0)
    # image rows grow downwards while +y is up (+v): a slope in rows is −dh/dv
    gy = np.where(along_v, 0.0, np.where(phase_y, -GROOVE_SLOPE, GROOVE_SLOPE))
    n = np.stack([-gx, -gy, np.ones_like(gx)], -1)
    # spherical cap per cell: n = (dx, dy, √(R² − r²)) / R with R = footprint / sin(rim)
    dx = (cols % cell + 0.5) - cell / 2.0                 # texel units, +x right
    dy = cell / 2.0 - (rows % cell + 0.5)                 # +y up (towards v = 1)
    foot = CAP_RADIUS * cell
    big_r = foot / CAP_RIM_SIN
    r2 = dx * dx + dy * dy
    inside = r2 < foot * foot
    cap = np.stack([dx, dy, np.sqrt(np.maximum(big_r * big_r - r2, 0.0))], -1)
    n = np.where(inside[..., None], cap, n)
    return normalize3(n)


def encode(n: np.ndarray, bits: int) -> np.ndarray:
    """(n + 1)/2 · (2^bits − 1), rounded to integers."""
    scale = float((1 << bits) - 1)
    return np.round((n * 0.5 + 0.5) * scale).astype(np.uint16 if bits == 16 else np.uint8)


def _write_png(path: Path, data: np.ndarray) -> None:
    import OpenImageIO as oiio
    from sgpipe.io.atomic import atomic_path
    h, w, c = data.shape
    t = oiio.UINT16 if data.dtype == np.uint16 else oiio.UINT8
    spec = oiio.ImageSpec(w, h, c, t)
    spec.attribute("Software", "sgpipe tools/sample_normalmaps.py")
    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create(str(tmp))
        if out is None or not out.open(str(tmp), spec):
            raise OSError(f"{path}: cannot write PNG: {oiio.geterror()}")
        out.write_image(np.ascontiguousarray(data))
        out.close()


def make(out: Path) -> dict:
    """Write FILES into `out`; return facts for the data_samples README."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    n = grooves_normals()
    _write_png(out / FILES[0], encode(n, 16))
    _write_png(out / FILES[1], encode(n, 8))
    return {"grooves_normal": {
        "files": list(FILES), "size": [SIZE, SIZE], "cells": CELLS,
        "groove_period_texels": GROOVE_PERIOD, "groove_slope": GROOVE_SLOPE,
        "cap_radius_cells": CAP_RADIUS, "cap_rim_sin": CAP_RIM_SIN,
        "encoding": "(n + 1)/2, 16-bit and 8-bit PNG, row 0 = v = 1"}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="output folder")
    args = ap.parse_args(argv)
    make(Path(args.out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
