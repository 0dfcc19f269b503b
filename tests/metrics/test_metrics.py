"""Image metrics: closed-form PSNR / relMSE, SSIM against a brute-force window sum."""

import math

import numpy as np
import pytest

from sgpipe import metrics


def _img(seed=0, h=24, w=32):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.1, 0.9, (h, w, 3))


def test_identical_images():
    a = _img()
    d = metrics.compare_images(a, a.copy())
    assert d["psnr_db"] == math.inf
    assert d["mse"] == 0.0 and d["rel_mse"] == 0.0 and d["max_abs_error"] == 0.0
    assert d["ssim"] == pytest.approx(1.0, abs=1e-12)


def test_psnr_exact_formula_for_known_error():
    """±δ on every pixel and channel: MSE = δ², PSNR = 20 log10(peak/δ)."""
    a = _img()
    sign = np.where(np.indices(a.shape).sum(0) % 2 == 0, 1.0, -1.0)
    for delta, peak in ((0.01, 1.0), (0.1, 1.0), (0.05, 4.0)):
        b = a + delta * sign
        assert metrics.mse(b, a) == pytest.approx(delta ** 2, rel=1e-12)
        assert metrics.psnr(b, a, peak=peak) == pytest.approx(20 * math.log10(peak / delta),
                                                               abs=1e-9)
    b = a + 0.01 * sign
    assert metrics.psnr(b, a, peak="max") == pytest.approx(
        20 * math.log10(a.max() / 0.01), abs=1e-9)


def test_psnr_of_gaussian_noise_matches_its_variance():
    """PSNR of x + N(0, σ²) ≈ 10 log10(1/σ²); tolerance from the χ² spread of the MSE."""
    rng = np.random.default_rng(3)
    a = np.full((128, 128, 3), 0.5)
    sigma = 0.02
    b = a + rng.normal(0.0, sigma, a.shape)
    n = a.size
    # MSE/σ² ~ χ²_n/n: relative std sqrt(2/n); 5 std in dB.
    tol_db = 10 * math.log10(1 + 5 * math.sqrt(2.0 / n))
    assert metrics.psnr(b, a) == pytest.approx(-10 * math.log10(sigma ** 2), abs=tol_db)


def test_relative_mse_formula():
    r = np.array([[[0.0, 1.0, 2.0]]])
    x = np.array([[[0.1, 1.5, 2.0]]])
    want = np.mean([0.01 / (0 + 0.01), 0.25 / (1 + 0.01), 0.0])
    assert metrics.relative_mse(x, r) == pytest.approx(want, rel=1e-12)


def test_ssim_matches_brute_force_window():
    """One interior pixel of ssim_map against an explicit 11×11 Gaussian-weighted sum."""
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 1, (30, 30, 3))
    y = np.clip(x + rng.normal(0, 0.1, x.shape), 0, None)
    m = metrics.ssim_map(x, y)
    lx, ly = metrics.luminance(x), metrics.luminance(y)
    r = np.arange(-5, 6)
    g = np.exp(-(r[:, None] ** 2 + r[None, :] ** 2) / (2 * 1.5 ** 2))
    g /= g.sum()
    i, j = 15, 12
    px, py = lx[i - 5:i + 6, j - 5:j + 6], ly[i - 5:i + 6, j - 5:j + 6]
    mx, my = (g * px).sum(), (g * py).sum()
    vx = (g * px * px).sum() - mx * mx
    vy = (g * py * py).sum() - my * my
    cxy = (g * px * py).sum() - mx * my
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    want = (2 * mx * my + c1) * (2 * cxy + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2))
    assert m[i, j] == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize("shape", [(5, 6), (12, 9), (40, 33)])
def test_ssim_map_everywhere_matches_reflected_gaussian_statistics(shape):
    """Every pixel, borders and images smaller than the 11-tap window included, against the
    local statistics by scipy's Gaussian filter with reflected borders."""
    from scipy.ndimage import gaussian_filter
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 1, (*shape, 3))
    y = np.clip(x + rng.normal(0, 0.1, x.shape), 0, None)
    lx, ly = metrics.luminance(x), metrics.luminance(y)

    def g(a):
        return gaussian_filter(a, 1.5, truncate=3.5, mode="reflect")
    mx, my = g(lx), g(ly)
    vx, vy, cxy = g(lx * lx) - mx * mx, g(ly * ly) - my * my, g(lx * ly) - mx * my
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    want = (2 * mx * my + c1) * (2 * cxy + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2))
    np.testing.assert_allclose(metrics.ssim_map(x, y), want, rtol=1e-9, atol=1e-12)


def test_ssim_decreases_with_noise():
    rng = np.random.default_rng(2)
    yy, xx = np.mgrid[0:64, 0:64] / 64.0
    a = np.stack([0.5 + 0.4 * np.sin(6 * xx) * np.cos(4 * yy)] * 3, -1)
    vals = [metrics.ssim(a + rng.normal(0, s, a.shape), a) for s in (0.0, 0.01, 0.03, 0.1, 0.3)]
    assert vals[0] == pytest.approx(1.0)
    assert all(v1 > v2 for v1, v2 in zip(vals, vals[1:])), vals
    assert vals[-1] < 0.5


def test_channel_handling_and_size_mismatch():
    a = _img()
    grey = a[:, :, :1]
    assert metrics.psnr(np.repeat(grey, 3, 2), grey) == math.inf
    rgba = np.concatenate([a, np.zeros(a.shape[:2] + (1,))], 2)
    assert metrics.psnr(rgba, a) == math.inf  # alpha ignored
    with pytest.raises(ValueError, match="differs"):
        metrics.psnr(a, a[:-1])


def test_mask_restricts_pixels():
    a = _img()
    b = a.copy()
    b[0, 0] += 1.0
    mask = np.ones(a.shape[:2], bool)
    mask[0, 0] = False
    assert metrics.psnr(b, a, mask=mask) == math.inf
    assert metrics.mse(b, a) == pytest.approx(3.0 / a.size)


def test_false_colour_difference():
    a = np.full((4, 6, 3), 0.5)
    b = a.copy()
    b[0, 0] += 0.2   # brighter
    b[1, 1] -= 0.2   # darker
    img = metrics.false_color_difference(b, a, scale=0.2)
    assert img.dtype == np.uint8 and img.shape == (4, 6, 3)
    assert (img[2:] == 0).all()                      # equal → black
    assert img[0, 0, 0] > 200 and img[0, 0, 0] > img[0, 0, 2]   # brighter → red/yellow
    assert img[1, 1, 2] > 200 and img[1, 1, 2] > img[1, 1, 0]   # darker → blue/cyan
    assert metrics.difference_scale(a, a) == 1.0
