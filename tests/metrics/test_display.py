"""Display PSNR (8-bit previews), ꟻLIP and surface masks against independent computations."""

import math

import numpy as np
import pytest

from sgpipe import metrics


def _linear_for_code(code):
    """The linear value whose sRGB preview is exactly this 8-bit code (inverse OETF)."""
    v = np.asarray(code, np.float64) / 255.0
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def test_display_psnr_is_psnr_of_the_8bit_codes():
    codes = np.full((6, 8, 3), 100)
    other = codes.copy()
    other[:3, :, 0] += 4                 # a quarter of a third of the values differ by 4
    other[5, 7, 2] -= 9                  # one value differs by 9
    mse = (3 * 8 * 16 + 81) / codes.size
    want = 10 * math.log10(255 ** 2 / mse)
    got = metrics.display_psnr(_linear_for_code(other), _linear_for_code(codes))
    assert got == pytest.approx(want, abs=1e-9)
    # exposure scales the radiance before the transform
    got = metrics.display_psnr(_linear_for_code(other) / 4, _linear_for_code(codes) / 4,
                               exposure=2)
    assert got == pytest.approx(want, abs=1e-9)
    # a mask selects the pixels: only the row with the 9 left
    m = np.zeros((6, 8), bool)
    m[5] = True
    got = metrics.display_psnr(_linear_for_code(other), _linear_for_code(codes), mask=m)
    assert got == pytest.approx(10 * math.log10(255 ** 2 / (81 / 24)), abs=1e-9)


def test_display_psnr_clamps_and_quantises():
    a = np.full((8, 8, 3), 0.5)
    b, c = a.copy(), a.copy()
    b[0, 0], c[0, 0] = 2.0, 5.0          # both white at exposure 0: no error
    assert metrics.display_psnr(c, b) == math.inf and metrics.psnr(c, b) < math.inf
    assert metrics.display_psnr(c, b, exposure=-2) < math.inf   # 0.5 vs 1.25 after 2^-2
    d = _linear_for_code(np.full((4, 4, 3), 128))
    e = d * 1.0005                       # well under half an 8-bit step: same codes
    assert metrics.display_psnr(e, d) == math.inf


def _pair(seed=0):
    rng = np.random.default_rng(seed)
    ref = rng.uniform(0.05, 0.8, (48, 48, 3))
    noise = rng.normal(0.0, 1.0, ref.shape)
    return ref, noise


def test_flip_zero_for_identical_and_monotone_in_the_difference():
    ref, noise = _pair()
    assert metrics.flip_ldr(ref, ref.copy()) == 0.0
    assert metrics.flip_hdr(ref * 8, ref * 8) == 0.0
    ldr = [metrics.flip_ldr(np.clip(ref + t * noise, 0, None), ref)
           for t in (0.01, 0.03, 0.1, 0.3)]
    hdr = [metrics.flip_hdr(np.clip(ref + t * noise, 0, None) * 8, ref * 8)
           for t in (0.01, 0.03, 0.1, 0.3)]
    assert 0 < ldr[0] and all(x < y for x, y in zip(ldr, ldr[1:])), ldr
    assert 0 < hdr[0] and all(x < y for x, y in zip(hdr, hdr[1:])), hdr
    assert ldr[-1] < 1 and hdr[-1] < 1


def test_ldr_flip_sees_the_display_image_hdr_flip_the_radiance():
    ref, _ = _pair(1)
    bright = ref + 2.0                   # white at exposure 0 whatever is added on top
    assert metrics.flip_ldr(bright + 1.0, bright) == 0.0
    assert metrics.flip_hdr(bright + 1.0, bright) > 0.0
    assert metrics.flip_ldr(bright + 1.0, bright, exposure=-3) > 0.0


def test_hdr_flip_of_black_reference_is_undefined_not_a_crash():
    z = np.zeros((8, 8, 3))
    assert metrics.flip_hdr(z + 0.1, z) is None
    assert metrics.compare_images(z + 0.1, z)["flip_hdr"] is None


def _surface_brute(ids):
    h, w = ids.shape
    out = np.zeros((h, w), bool)
    for y in range(h):
        for x in range(w):
            nb = {ids[j, i] for j in range(max(0, y - 1), min(h, y + 2))
                  for i in range(max(0, x - 1), min(w, x + 2))}
            out[y, x] = ids[y, x] >= 0 and nb == {ids[y, x]}
    return out


def test_surface_mask_from_synthetic_object_ids():
    ids = np.full((12, 16), -1)
    ids[2:9, 1:7] = 0
    ids[4:12, 6:16] = 3                  # overlaps object 0: a shared silhouette
    ids[0, 15] = 3
    m = metrics.surface_mask(ids)
    assert np.array_equal(m, _surface_brute(ids))
    assert m[6, 3] and not m[6, 6] and not m[6, 1] and m[11, 15] and not m[0, 15]
    rng = np.random.default_rng(5)
    rnd = rng.integers(-1, 2, (20, 20))
    rnd[5:15, 5:15] = 1
    assert np.array_equal(metrics.surface_mask(rnd), _surface_brute(rnd))


def test_compare_images_surface_variants_are_the_masked_metrics():
    ref, noise = _pair(2)
    img = np.clip(ref + 0.05 * noise, 0, None)
    ids = np.full(ref.shape[:2], -1)
    ids[10:40, 8:30] = 2
    surf = metrics.surface_mask(ids)
    d = metrics.compare_images(img, ref, surface=surf)
    s = d["surface"]
    assert s["pixels"] == int(surf.sum()) == 28 * 20
    assert s["display_psnr_db"] == pytest.approx(metrics.display_psnr(img, ref, mask=surf))
    assert s["rel_mse"] == pytest.approx(metrics.relative_mse(img, ref, mask=surf))
    assert s["flip_ldr"] == pytest.approx(
        float(metrics.flip_ldr_map(img, ref)[surf].mean()))
    assert d["display_psnr_db"] == pytest.approx(metrics.display_psnr(img, ref))
    assert s["display_psnr_db"] != d["display_psnr_db"]
