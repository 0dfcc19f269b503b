"""Tiny raster plots for fit reports (no matplotlib): error-vs-lobes curves (Green06 Fig 5
style) and function-vs-fit slice previews, drawn straight into float RGB arrays."""

from __future__ import annotations

import numpy as np

# 3×5 bitmap glyphs (rows top→bottom, 3 bits each) for tick labels.
_GLYPHS = {
    "0": (7, 5, 5, 5, 7), "1": (2, 6, 2, 2, 7), "2": (7, 1, 7, 4, 7), "3": (7, 1, 7, 1, 7),
    "4": (5, 5, 7, 1, 1), "5": (7, 4, 7, 1, 7), "6": (7, 4, 7, 5, 7), "7": (7, 1, 1, 1, 1),
    "8": (7, 5, 7, 5, 7), "9": (7, 5, 7, 1, 7), ".": (0, 0, 0, 0, 2), "-": (0, 0, 7, 0, 0),
    "e": (0, 7, 7, 4, 7), " ": (0, 0, 0, 0, 0),
}
COLOURS = [(0.85, 0.1, 0.1), (0.1, 0.35, 0.85), (0.1, 0.6, 0.2), (0.8, 0.5, 0.0),
           (0.5, 0.1, 0.7), (0.0, 0.6, 0.6), (0.4, 0.4, 0.4), (0.9, 0.3, 0.6)]


def draw_text(img, x: int, y: int, text: str, colour=(0.0, 0.0, 0.0), scale: int = 2):
    """Draw `text` with the 3×5 font, top-left at (x, y)."""
    for n, ch in enumerate(text):
        rows = _GLYPHS.get(ch, _GLYPHS[" "])
        for r, bits in enumerate(rows):
            for c in range(3):
                if bits >> (2 - c) & 1:
                    y0, x0 = y + r * scale, x + (n * 4 + c) * scale
                    img[max(y0, 0):y0 + scale, max(x0, 0):x0 + scale] = colour


def _line(img, p0, p1, colour, width=2):
    n = int(max(abs(p1[0] - p0[0]), abs(p1[1] - p0[1]))) * 2 + 2
    xs = np.linspace(p0[0], p1[0], n).round().astype(int)
    ys = np.linspace(p0[1], p1[1], n).round().astype(int)
    h, w = img.shape[:2]
    for dx in range(width):
        for dy in range(width):
            ok = (xs + dx < w) & (ys + dy < h) & (xs + dx >= 0) & (ys + dy >= 0)
            img[ys[ok] + dy, xs[ok] + dx] = colour


def plot_curves(series: list[tuple[list[float], list[float]]], *, width: int = 480,
                height: int = 320, log_y: bool = True) -> np.ndarray:
    """Line plot of (x, y) series on a white RGB float image; log10 y axis with decade labels."""
    img = np.ones((height, width, 3))
    left, right, top, bottom = 56, 16, 16, 36
    xs = np.concatenate([np.asarray(s[0], float) for s in series]) if series else np.zeros(1)
    ys = np.concatenate([np.asarray(s[1], float) for s in series]) if series else np.ones(1)
    ys = ys[np.isfinite(ys) & (ys > 0)] if log_y else ys[np.isfinite(ys)]
    tf = np.log10 if log_y else (lambda v: np.asarray(v, float))
    lo, hi = (np.floor(tf(ys.min())), np.ceil(tf(ys.max()))) if ys.size else (0.0, 1.0)
    hi = hi if hi > lo else lo + 1
    x_lo, x_hi = float(xs.min()), float(max(xs.max(), xs.min() + 1))

    def px(x, y):
        u = left + (x - x_lo) / (x_hi - x_lo) * (width - left - right)
        v = top + (hi - tf(max(y, 1e-300) if log_y else y)) / (hi - lo) * (height - top - bottom)
        return u, v

    for d in range(int(lo), int(hi) + 1):                       # horizontal decade grid
        _, v = px(x_lo, 10.0**d if log_y else d)
        _line(img, (left, v), (width - right, v), (0.85, 0.85, 0.85), 1)
        draw_text(img, 4, int(v) - 5, f"1e{d}" if log_y else f"{d}")
    for x in range(int(np.ceil(x_lo)), int(x_hi) + 1):          # integer x ticks
        u, _ = px(x, 10.0**lo if log_y else lo)
        _line(img, (u, height - bottom), (u, height - bottom + 4), (0, 0, 0), 1)
        draw_text(img, int(u) - 3, height - bottom + 8, str(x))
    _line(img, (left, top), (left, height - bottom), (0, 0, 0), 1)
    _line(img, (left, height - bottom), (width - right, height - bottom), (0, 0, 0), 1)
    for k, (sx, sy) in enumerate(series):
        col = COLOURS[k % len(COLOURS)]
        pts = [px(x, y) for x, y in zip(sx, sy) if np.isfinite(y) and (y > 0 or not log_y)]
        for a, b in zip(pts[:-1], pts[1:]):
            _line(img, a, b, col, 2)
        for u, v in pts:
            img[int(v) - 3:int(v) + 4, int(u) - 3:int(u) + 4] = col
    return img


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


def slice_panels(rows: list[tuple[np.ndarray, np.ndarray]], gap: int = 4) -> np.ndarray:
    """Rows of [function | fit | |difference| (red)], each row scaled by the function's max."""
    res = rows[0][0].shape[0]
    img = np.ones((len(rows) * (res + gap) + gap, 3 * (res + gap) + gap, 3))
    for r, (f, g) in enumerate(rows):
        s = 1.0 / max(float(f.max()), 1e-300)
        y0 = gap + r * (res + gap)
        for c, panel in enumerate((f * s, g * s)):
            x0 = gap + c * (res + gap)
            img[y0:y0 + res, x0:x0 + res] = np.clip(panel, 0, 1)[..., None]
        x0 = gap + 2 * (res + gap)
        diff = np.clip(np.abs(f - g) * s, 0, 1)
        img[y0:y0 + res, x0:x0 + res] = np.stack([diff, 0 * diff, 0 * diff], -1)
    return img
