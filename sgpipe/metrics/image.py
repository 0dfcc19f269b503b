"""Image metrics against a reference: linear PSNR, SSIM, relative MSE, false-colour difference.

Conventions (the `compare` command, the render stage and docs/RESULTS.md all use these):

* Inputs are linear float radiance, (H, W), (H, W, 1), (H, W, 3) or (H, W, 4); only the
  first three channels are used (alpha is ignored), one channel is treated as grey.
* **linear PSNR** = 10 log10(peak² / MSE), MSE over every pixel and RGB channel of the *linear*
  radiance (no tone mapping, no clamping). The peak is fixed at ``PSNR_PEAK = 1.0`` — the
  value that the PNG previews show as white (sgpipe.io.png) — so numbers are comparable
  between scenes and methods; ``peak="max"`` uses the reference maximum instead. Identical
  images give ``inf``.
* **SSIM** (Wang et al. 2004) on the Rec. 709 luminance Y = 0.2126 R + 0.7152 G + 0.0722 B
  of the linear radiance, Gaussian window σ = 1.5 truncated at 3.5σ (11×11), K1 = 0.01,
  K2 = 0.03, dynamic range L = the PSNR peak, reflected borders, mean over all pixels.
* **relative MSE** = mean over pixels and channels of (x − r)² / (r² + ε), ε = 0.01
  (the usual rendering "relMSE"; ε keeps black pixels from dominating).
* **Display PSNR and ꟻLIP** (what a viewer sees, the numbers to use for goals): see
  sgpipe.metrics.display. The linear PSNR above is kept as ``psnr_db`` and always labelled
  "linear PSNR": on HDR frames it is decided by the few brightest pixels.
* **False-colour difference**: signed luminance difference x − r divided by a scale (the 99th
  percentile of |x − r| unless given); black = equal, red → yellow where the image is brighter
  than the reference, blue → cyan where it is darker. Returned as 8-bit sRGB-ready RGB.
"""

from __future__ import annotations

import math

import numpy as np

from sgpipe.metrics import display

PSNR_PEAK = 1.0
REL_MSE_EPS = 0.01
SSIM_SIGMA = 1.5
SSIM_TRUNCATE = 3.5
SSIM_K1 = 0.01
SSIM_K2 = 0.03
LUMINANCE_WEIGHTS = (0.2126, 0.7152, 0.0722)


def as_rgb(image: np.ndarray) -> np.ndarray:
    """(H, W[, C]) -> float64 (H, W, 3): first three channels, grey broadcast, alpha dropped."""
    img = np.asarray(image, dtype=np.float64)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or img.shape[2] < 1:
        raise ValueError(f"expected an (H, W[, C]) image, got shape {img.shape}")
    if img.shape[2] == 1:
        return np.repeat(img, 3, axis=2)
    if img.shape[2] == 2:
        raise ValueError("2-channel images are not supported")
    return img[:, :, :3]


def luminance(image: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of linear RGB -> (H, W)."""
    return as_rgb(image) @ np.asarray(LUMINANCE_WEIGHTS)


def _pair(image, reference, mask=None):
    a, r = as_rgb(image), as_rgb(reference)
    if a.shape != r.shape:
        raise ValueError(f"image size {a.shape[1]}x{a.shape[0]} differs from reference size "
                         f"{r.shape[1]}x{r.shape[0]}")
    if mask is not None:
        m = np.asarray(mask, bool)
        if m.shape != a.shape[:2]:
            raise ValueError(f"mask shape {m.shape} does not match image {a.shape[:2]}")
        return a[m], r[m]
    return a, r


def _peak(reference, peak):
    if peak == "max":
        p = float(np.max(as_rgb(reference)))
        return p if p > 0 else 1.0
    p = float(peak)
    if not p > 0:
        raise ValueError(f"peak must be > 0, got {peak!r}")
    return p


def mse(image, reference, *, mask=None) -> float:
    """Mean squared error over pixels and RGB channels (linear radiance)."""
    a, r = _pair(image, reference, mask)
    if a.size == 0:
        return 0.0
    return float(np.mean((a - r) ** 2))


def psnr(image, reference, *, peak: float | str = PSNR_PEAK, mask=None) -> float:
    """10 log10(peak² / MSE) on linear radiance; ``inf`` for identical images."""
    e = mse(image, reference, mask=mask)
    p = _peak(reference, peak)
    if e == 0.0:
        return math.inf
    return 10.0 * math.log10(p * p / e)


def relative_mse(image, reference, *, eps: float = REL_MSE_EPS, mask=None) -> float:
    """mean((x − r)² / (r² + eps)) over pixels and RGB channels."""
    a, r = _pair(image, reference, mask)
    if a.size == 0:
        return 0.0
    return float(np.mean((a - r) ** 2 / (r * r + eps)))


def ssim_map(image, reference, *, peak: float | str = PSNR_PEAK) -> np.ndarray:
    """Per-pixel SSIM of the luminances (Wang et al. 2004 eq 13 with Gaussian local stats)."""
    from skimage.metrics import structural_similarity
    _pair(image, reference)
    x, y = luminance(image), luminance(reference)
    # win_size only sets scikit-image's border crop of the mean, which we do not use: below
    # its default 11 taps it must just be odd and fit the image (the map is the same)
    side = min(x.shape)
    win = None if side >= 11 else side - 1 + side % 2
    # Wang et al.'s constants and Gaussian window (σ 1.5, population covariance), as published
    _, full = structural_similarity(
        x, y, data_range=_peak(reference, peak), gaussian_weights=True, sigma=SSIM_SIGMA,
        truncate=SSIM_TRUNCATE, use_sample_covariance=False, K1=SSIM_K1, K2=SSIM_K2,
        win_size=win, full=True)
    return full


def ssim(image, reference, *, peak: float | str = PSNR_PEAK, mask=None) -> float:
    """Mean SSIM of the luminances (1 for identical images)."""
    m = ssim_map(image, reference, peak=peak)
    if mask is not None:
        m = m[np.asarray(mask, bool)]
    return float(np.mean(m)) if m.size else 1.0


def _metrics(image, reference, mask, peak, exposure, flips) -> dict:
    ldr, hdr = flips
    return {
        "display_psnr_db": display.display_psnr(image, reference, exposure=exposure, mask=mask),
        "flip_ldr": display.mean_over(ldr, mask),
        "flip_hdr": display.mean_over(hdr, mask),
        "rel_mse": relative_mse(image, reference, mask=mask),
        "psnr_db": psnr(image, reference, peak=peak, mask=mask),
        "ssim": ssim(image, reference, peak=peak, mask=mask),
        "mse": mse(image, reference, mask=mask),
    }


def compare_images(image, reference, *, peak: float | str = PSNR_PEAK, mask=None,
                   exposure: float = 0.0, surface=None) -> dict:
    """Every metric as a dict: display_psnr_db, flip_ldr, flip_hdr, rel_mse, psnr_db (linear),
    ssim, mse, peak, exposure, max_abs_error; with a `surface` mask (surface.surface_mask) also
    "surface": the same metrics over those pixels and their count."""
    a, r = _pair(image, reference, mask)
    flips = (display.flip_ldr_map(image, reference, exposure=exposure),
             display.flip_hdr_map(image, reference))
    out = _metrics(image, reference, mask, peak, exposure, flips)
    out.update(peak=_peak(reference, peak), exposure=float(exposure),
               max_abs_error=float(np.max(np.abs(a - r))) if a.size else 0.0)
    if surface is not None:
        m = np.asarray(surface, bool) & (True if mask is None else np.asarray(mask, bool))
        out["surface"] = _metrics(image, reference, m, peak, exposure, flips)
        out["surface"]["pixels"] = int(m.sum())
    return out


# piecewise-linear ramps for the false-colour map: t in [0, 1] -> RGB
_POS = np.array([[0, 0, 0], [0.8, 0.05, 0.0], [1.0, 0.55, 0.0], [1.0, 1.0, 0.6]])
_NEG = np.array([[0, 0, 0], [0.05, 0.2, 0.85], [0.0, 0.7, 1.0], [0.7, 1.0, 1.0]])


def _ramp(t, stops):
    x = np.clip(t, 0.0, 1.0) * (len(stops) - 1)
    i = np.minimum(x.astype(int), len(stops) - 2)
    f = (x - i)[..., None]
    return stops[i] * (1 - f) + stops[i + 1] * f


def difference_scale(image, reference, *, percentile: float = 99.0) -> float:
    """Default colour scale of `false_color_difference`: a percentile of |ΔY| (> 0)."""
    d = np.abs(luminance(image) - luminance(reference))
    s = float(np.percentile(d, percentile)) if d.size else 0.0
    if s <= 0:
        s = float(d.max()) if d.size else 0.0
    return s if s > 0 else 1.0


def false_color_difference(image, reference, *, scale: float | None = None) -> np.ndarray:
    """Signed luminance difference -> uint8 (H, W, 3) (see the module docstring)."""
    _pair(image, reference)
    d = luminance(image) - luminance(reference)
    s = difference_scale(image, reference) if scale is None else float(scale)
    t = d / s
    rgb = np.where((t >= 0)[..., None], _ramp(t, _POS), _ramp(-t, _NEG))
    return np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)


__all__ = ["PSNR_PEAK", "REL_MSE_EPS", "as_rgb", "luminance", "mse", "psnr", "relative_mse",
           "ssim", "ssim_map", "compare_images", "false_color_difference", "difference_scale"]
