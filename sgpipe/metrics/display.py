"""What a viewer sees: display PSNR of the 8-bit previews and ꟻLIP (Andersson et al. 2020, 2021).

Conventions (`sgpipe compare`, the render stage's report and docs/RESULTS.md use these):

* **Display image**: the preview transform of sgpipe.io.png.tonemap_srgb — scale by 2^exposure
  (`render.preview_exposure`), clamp to [0, 1], sRGB OETF, round to 8 bits. Radiance above 1
  at that exposure is white in both images and carries no error.
* **Display PSNR** = 10 log10(255² / MSE) over every pixel and RGB channel of the two 8-bit
  display images (quantised, the values a viewer's PNG holds); ``inf`` when they are equal.
* **LDR-ꟻLIP**: NVIDIA's `flip_evaluator` on the display images (as sRGB in [0, 1], default
  67 pixels per degree), mean of its per-pixel error map; 0 = identical, 1 = maximal.
* **HDR-ꟻLIP**: `flip_evaluator` on the linear radiance (negatives clamped to 0, no exposure
  scale: HDR-ꟻLIP picks its exposure range from the reference), ACES tone mapper, mean of the
  map. Undefined (None) for an all-black reference, where ꟻLIP has no exposure range.
* A mask (e.g. `surface_mask`) selects the pixels that enter the mean; ꟻLIP maps are always
  computed on the whole frame (its filters see the neighbourhood) and then averaged.
"""

from __future__ import annotations

import math

import numpy as np

from sgpipe.io.png import tonemap_srgb

DISPLAY_PEAK = 255.0


def display_image(image, *, exposure: float = 0.0) -> np.ndarray:
    """Linear RGB (H, W, 3) -> the 8-bit preview a viewer sees (uint8, (H, W, 3))."""
    return tonemap_srgb(np.asarray(image, np.float64)[..., :3], exposure=exposure)


def _select(x, mask):
    return x if mask is None else x[np.asarray(mask, bool)]


def display_psnr(image, reference, *, exposure: float = 0.0, mask=None) -> float:
    """10 log10(255² / MSE) of the 8-bit display images (module docstring); inf if equal."""
    a = _select(display_image(image, exposure=exposure).astype(np.float64), mask)
    r = _select(display_image(reference, exposure=exposure).astype(np.float64), mask)
    if a.size == 0:
        return math.inf
    e = float(np.mean((a - r) ** 2))
    return math.inf if e == 0.0 else 10.0 * math.log10(DISPLAY_PEAK ** 2 / e)


def _flip_map(reference, test, dynamic_range: str) -> np.ndarray:
    from flip_evaluator import evaluate
    err, _, _ = evaluate(np.ascontiguousarray(reference, np.float32),
                         np.ascontiguousarray(test, np.float32), dynamic_range,
                         applyMagma=False, computeMeanError=False)
    return np.asarray(err, np.float64).reshape(np.shape(reference)[:2])


def flip_ldr_map(image, reference, *, exposure: float = 0.0) -> np.ndarray:
    """Per-pixel LDR-ꟻLIP of the display images, (H, W) in [0, 1]."""
    a = display_image(image, exposure=exposure) / 255.0
    r = display_image(reference, exposure=exposure) / 255.0
    return _flip_map(r, a, "LDR")


def flip_hdr_map(image, reference) -> np.ndarray | None:
    """Per-pixel HDR-ꟻLIP of the linear radiance, (H, W); None for an all-black reference."""
    r = np.maximum(np.asarray(reference, np.float64)[..., :3], 0.0)
    a = np.maximum(np.asarray(image, np.float64)[..., :3], 0.0)
    if not np.any(r > 0):
        return None                    # flip_evaluator exits the process on this input
    return _flip_map(r, a, "HDR")


def mean_over(error_map, mask=None) -> float | None:
    """Mean of a per-pixel map over the mask (None for a None map, 0 for an empty mask)."""
    if error_map is None:
        return None
    sel = _select(error_map, mask)
    return float(np.mean(sel)) if sel.size else 0.0


def flip_ldr(image, reference, *, exposure: float = 0.0, mask=None) -> float:
    """Mean LDR-ꟻLIP (0 = identical)."""
    return mean_over(flip_ldr_map(image, reference, exposure=exposure), mask)


def flip_hdr(image, reference, *, mask=None) -> float | None:
    """Mean HDR-ꟻLIP (0 = identical; None for an all-black reference)."""
    return mean_over(flip_hdr_map(image, reference), mask)
