"""Pixel reconstruction filters of the `reference` method and its sub-pixel sample pattern.

A pixel's value is I = ∫ f(x − c) L(x) dx / ∫ f over the image plane (x in pixel units, c the
pixel centre). The reference draws each sample's image-plane offset x − c from the normalised
filter itself (filter importance sampling), so every sample has weight 1 and I is the plain
mean of the samples' radiance. Filters are separable, f(x, y) = f₁(x)·f₁(y):

* `box` (radius r, default ½: the pixel): f₁ = 1 on [−r, r];
* `tent` (radius r, default 1): f₁ = max(0, 1 − |x|/r);
* `gaussian` (stddev σ, default ½; radius 4σ unless given): f₁ = max(0, e^{−x²/2σ²} −
  e^{−r²/2σ²}) (Mitsuba 3's `gaussian` rfilter: truncated and shifted to reach 0 at r);
* `center`: every sample through the pixel centre (no integration over the pixel; what the
  real-time methods do without supersampling).

The 2-D uniforms per (pixel, sample) are the R2 low-discrepancy sequence (Roberts 2018: the
additive recurrence with the plastic number, u_s = frac(s·(1/φ₂, 1/φ₂²))) shifted per pixel by
a hashed Cranley–Patterson rotation: every prefix of a pixel's samples is well stratified over
the footprint (progressive checkpoints too), and the pattern is a pure function of (seed,
pixel, sample index).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sgpipe.reference import _sampling_jit as jit

FILTER_TYPES = ("box", "tent", "gaussian", "center")
_PLASTIC = 1.32471795724474602596
_R2 = np.array([1.0 / _PLASTIC, 1.0 / (_PLASTIC * _PLASTIC)])
_PIXEL_STREAM = 0x9A7E1F11  # seed tweak: the pixel pattern's stream, apart from the shading's


@dataclass(frozen=True)
class PixelFilter:
    """A separable pixel filter; `radius` None means the type's default (see module doc)."""

    type: str = "box"
    radius: float | None = None
    stddev: float = 0.5

    def __post_init__(self):
        if self.type not in FILTER_TYPES:
            raise ValueError(f"pixel filter type must be one of {FILTER_TYPES}, got "
                             f"{self.type!r}")
        if self.radius is not None and not self.radius > 0:
            raise ValueError(f"pixel filter radius must be > 0, got {self.radius}")
        if not self.stddev > 0:
            raise ValueError(f"pixel filter stddev must be > 0, got {self.stddev}")

    @classmethod
    def of(cls, spec) -> "PixelFilter":
        """From a PixelFilter, a type name, a dict / config object with type, radius, stddev,
        or None (box)."""
        if isinstance(spec, PixelFilter):
            return spec
        if spec is None:
            return cls()
        if isinstance(spec, str):
            return cls(spec)
        get = spec.get if isinstance(spec, dict) else lambda k, d=None: getattr(spec, k, d)
        return cls(str(get("type", "box")), get("radius", None), float(get("stddev", 0.5)))

    @property
    def extent(self) -> float:
        """Half-width r of the support in pixels (0 for `center`)."""
        if self.type == "center":
            return 0.0
        if self.radius is not None:
            return float(self.radius)
        return {"box": 0.5, "tent": 1.0, "gaussian": 4.0 * self.stddev}[self.type]

    def weight_1d(self, x) -> np.ndarray:
        """The unnormalised 1-D profile f₁(x) (x in pixels)."""
        x = np.abs(np.asarray(x, np.float64))
        r = self.extent
        if self.type == "box":
            return (x <= r).astype(np.float64)
        if self.type == "tent":
            return np.maximum(0.0, 1.0 - x / r)
        if self.type == "gaussian":
            a = -0.5 / (self.stddev * self.stddev)
            return np.where(x <= r, np.maximum(0.0, np.exp(a * x * x) - math.exp(a * r * r)), 0.0)
        raise ValueError("the center filter has no profile")

    def density_1d(self, x) -> np.ndarray:
        """f₁ normalised to integrate to 1 over [−r, r] (the per-axis sampling density)."""
        return self.weight_1d(x) / self._norm()

    def _norm(self) -> float:
        r = self.extent
        if self.type == "box":
            return 2.0 * r
        if self.type == "tent":
            return r
        # Gaussian: σ√(2π)·erf(r/(σ√2)) minus the shift's 2r·e^{−r²/2σ²}
        s = self.stddev
        return (s * math.sqrt(2 * math.pi) * math.erf(r / (s * math.sqrt(2)))
                - 2 * r * math.exp(-0.5 * r * r / (s * s)))

    def warp(self, u) -> np.ndarray:
        """Uniforms in [0, 1) (any shape) → offsets from the pixel centre (pixels), per axis
        distributed with density_1d (inverse CDF)."""
        u = np.asarray(u, np.float64)
        r = self.extent
        if self.type == "center":
            return np.zeros_like(u)
        if self.type == "box":
            return (2.0 * u - 1.0) * r
        if self.type == "tent":
            return np.where(u < 0.5, r * (np.sqrt(2.0 * u) - 1.0),
                            r * (1.0 - np.sqrt(2.0 * (1.0 - u))))
        xs, cdf = self._gaussian_table()
        return np.interp(u, cdf, xs)

    def _gaussian_table(self, n: int = 8193):
        """Tabulated inverse CDF of the truncated Gaussian (exact integral per interval of the
        piecewise-linear density: error ~1e-8 of a pixel)."""
        r = self.extent
        xs = np.linspace(-r, r, n)
        f = self.weight_1d(xs)
        c = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(xs))])
        return xs, c / c[-1]


def pixel_uniforms(seed: int, pixel_ids: np.ndarray, s0: int, ns: int) -> np.ndarray:
    """(P, ns, 2) uniforms of samples s0 .. s0+ns−1: R2 sequence + per-pixel hashed shift."""
    shift = jit.uniforms(np.uint64((int(seed) ^ _PIXEL_STREAM) & 0xFFFFFFFFFFFFFFFF),
                         np.asarray(pixel_ids, np.int64), 0, 1, 2)          # (P, 1, 2)
    s = np.arange(s0, s0 + ns, dtype=np.float64)[None, :, None] + 1.0
    return np.mod(shift + s * _R2[None, None, :], 1.0)


def subpixel_positions(filt: PixelFilter, seed: int, pixel_ids: np.ndarray, s0: int,
                       ns: int) -> np.ndarray:
    """(P, ns, 2) sub-pixel positions (ox, oy) of the samples (CONVENTIONS: (½, ½) = the pixel
    centre; may leave [0, 1)² when the filter is wider than the pixel)."""
    if filt.type == "center":
        return np.full((len(pixel_ids), ns, 2), 0.5)
    return 0.5 + filt.warp(pixel_uniforms(seed, pixel_ids, s0, ns))
