"""Pixel filtering of the `reference` (sgpipe.reference.pixel_filter): a black/white half-plane
edge against its analytic coverage (box) and the filter-weighted coverage by quadrature (tent,
Gaussian); filter densities integrate to 1 and their samplers follow them (χ²); a constant
scene stays constant under every filter; the sample pattern is deterministic."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import chi2

from sgpipe.reference import PixelFilter, render_reference_result
from sgpipe.reference.pixel_filter import subpixel_positions
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject

WHITE = [("lambert", {"kd": 1.0})]


def _edge_scene(theta=0.37, p0=(0.03, -0.05, 0.0)):
    """A plane z = 0 bounded by one straight edge crossing the view (the rest far outside)."""
    e = np.array([np.cos(theta), np.sin(theta), 0.0])
    nrm = np.array([-np.sin(theta), np.cos(theta), 0.0])
    p0 = np.asarray(p0)
    v = np.array([p0 - 20 * e, p0 + 20 * e, p0 + 20 * e - 20 * nrm, p0 - 20 * e - 20 * nrm])
    cam = Camera(eye=(0, 0, 3), target=(0, 0, 0), fov_deg=30, width=24, height=24)
    a, b = cam.project(np.array([p0 - 5 * e, p0 + 5 * e]))      # the edge in pixel units
    inside = cam.project((p0 - 0.5 * nrm)[None])[0]
    nn = np.array([-(b - a)[1], (b - a)[0]])
    nn = nn * np.sign(nn @ (inside - a))                          # (q − a)·nn > 0 inside
    return [TraceObject.mesh("plane", v, [[0, 1, 2], [0, 2, 3]])], cam, a, nn


def _box_coverage(cam, a, nn):
    """Exact area of each pixel square inside the half-plane (polygon clipping)."""
    out = np.zeros((cam.height, cam.width))
    for i in range(cam.height):
        for j in range(cam.width):
            poly = [(j, i), (j + 1, i), (j + 1, i + 1), (j, i + 1)]
            f = lambda p: (p[0] - a[0]) * nn[0] + (p[1] - a[1]) * nn[1]  # noqa: E731
            clip = []
            for k in range(4):
                p, q = poly[k], poly[(k + 1) % 4]
                fp, fq = f(p), f(q)
                if fp >= 0:
                    clip.append(p)
                if (fp >= 0) != (fq >= 0):
                    s = fp / (fp - fq)
                    clip.append((p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])))
            if len(clip) >= 3:
                x, y = np.array(clip).T
                out[i, j] = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    return out


def _filtered_coverage(filt, cam, a, nn, n=400):
    """∫∫ f(x) f(y) [centre + (x, y) inside] by the midpoint rule (weights renormalised)."""
    r = filt.extent
    x = (np.arange(n) + 0.5) / n * 2 * r - r
    wgt = np.outer(filt.density_1d(x), filt.density_1d(x))
    wgt /= wgt.sum()
    out = np.zeros((cam.height, cam.width))
    for i in range(cam.height):
        for j in range(cam.width):
            ins = ((j + 0.5 + x[None, :] - a[0]) * nn[0] + (i + 0.5 + x[:, None] - a[1]) * nn[1]
                   ) > 0
            out[i, j] = wgt[ins].sum()
    return out


@pytest.mark.parametrize("ftype", ["box", "tent", "gaussian"])
def test_half_plane_edge_coverage(ftype):
    """White Lambert plane (ρ = 1) under a white environment, black background, BRDF sampling:
    every hit sample is exactly 1, every miss 0, so a pixel is its filtered coverage of the
    half-plane. 256 spp of the stratified pattern: RMS error over edge pixels 0.0054 (box),
    0.0055 (tent), 0.0062 (Gaussian), a quarter of i.i.d. sampling's √(c(1−c)/N)."""
    objs, cam, a, nn = _edge_scene()
    filt = PixelFilter(ftype)
    want = _box_coverage(cam, a, nn) if ftype == "box" else _filtered_coverage(filt, cam, a, nn)
    res = render_reference_result(objs, cam, np.ones((8, 16, 3)), materials=WHITE, spp=256,
                                  seed=1, workers=1, strategy="brdf", background="black",
                                  pixel_filter=filt)
    img = res.image[..., 0].astype(np.float64)
    assert np.array_equal(res.image[..., 0], res.image[..., 2])
    np.testing.assert_allclose(img, res.coverage, atol=1e-6)    # hit samples are exactly 1
    eps = 0.0 if ftype == "box" else 1e-3                         # quadrature of the truth
    edge = (want > eps) & (want < 1 - eps)
    assert edge.sum() > 25
    d = img - want
    iid = np.sqrt(np.mean(want[edge] * (1 - want[edge]) / 256))
    assert np.sqrt(np.mean(d[edge] ** 2)) < 0.4 * iid, (np.sqrt(np.mean(d[edge] ** 2)), iid)
    assert np.abs(d[edge]).max() < 0.03
    # outside the edge band: exact (box) or off by at most one of 256 samples in a filter tail
    assert np.abs(d[~edge]).max() <= (1e-9 if ftype == "box" else 1 / 256 + 1e-3)
    # pixel-centre rays alias: each pixel is 0 or 1, the centre's side of the edge
    c = render_reference_result(objs, cam, np.ones((8, 16, 3)), materials=WHITE, spp=4,
                                seed=1, workers=1, strategy="brdf", background="black",
                                pixel_filter="center")
    centre_in = ((np.arange(24)[None, :] + 0.5 - a[0]) * nn[0]
                 + (np.arange(24)[:, None] + 0.5 - a[1]) * nn[1]) > 0
    np.testing.assert_allclose(c.image[..., 0], centre_in.astype(float), atol=1e-6)


@pytest.mark.parametrize("filt", [PixelFilter("box"), PixelFilter("box", radius=1.5),
                                  PixelFilter("tent"), PixelFilter("tent", radius=2.0),
                                  PixelFilter("gaussian"), PixelFilter("gaussian", stddev=0.3,
                                                                       radius=1.0)])
def test_filter_density_integrates_to_one_and_sampler_follows_it(filt):
    r = filt.extent
    total, _ = quad(filt.density_1d, -r, r, points=[0.0], limit=200)
    assert total == pytest.approx(1.0, abs=1e-9)
    x = filt.warp(np.random.default_rng(3).random(200_000))
    assert np.abs(x).max() <= r + 1e-12
    edges = np.linspace(-r, r, 41)
    p = np.array([quad(filt.density_1d, lo, hi)[0] for lo, hi in zip(edges[:-1], edges[1:])])
    counts = np.histogram(x, edges)[0]
    exp = p * len(x)
    ok = exp > 5
    stat = np.sum((counts[ok] - exp[ok]) ** 2 / exp[ok])
    assert chi2.sf(stat, ok.sum() - 1) > 1e-3


@pytest.mark.parametrize("ftype", ["box", "tent", "gaussian"])
def test_constant_scene_stays_constant(ftype):
    """White furnace (ρ = 1 sphere in a white environment): every sample is 1, so every pixel
    is 1 exactly, silhouettes included, whatever the filter's reach beyond the pixel."""
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), fov_deg=32, width=16, height=16)
    res = render_reference_result([TraceObject.sphere("s", (0, 0, 0), 1.0)], cam,
                                  np.ones((8, 16, 3)), materials=WHITE, spp=16, seed=2,
                                  workers=1, strategy="brdf", pixel_filter=ftype)
    assert 0 < np.sum((res.coverage > 0) & (res.coverage < 1))
    np.testing.assert_allclose(res.image, 1.0, atol=2e-6)


def test_sample_pattern_is_deterministic_and_stratified():
    f = PixelFilter("box")
    pid = np.arange(50, dtype=np.int64)
    a = subpixel_positions(f, 7, pid, 0, 64)
    np.testing.assert_array_equal(a, subpixel_positions(f, 7, pid, 0, 64))
    np.testing.assert_array_equal(a[:, 10:20], subpixel_positions(f, 7, pid, 10, 10))
    assert not np.array_equal(a, subpixel_positions(f, 8, pid, 0, 64))
    assert (a >= 0).all() and (a < 1).all()
    # stratified: each of a pixel's 64 samples' 8×8 cells holds about one sample (i.i.d. would
    # leave ~37 % of the cells empty)
    cells = (a[..., 0] * 8).astype(int) * 8 + (a[..., 1] * 8).astype(int)
    empty = np.mean([64 - len(np.unique(c)) for c in cells]) / 64
    assert empty < 0.2, empty
