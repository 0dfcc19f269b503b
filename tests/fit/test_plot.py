"""sgpipe.fit.plot: matplotlib figures with labelled axes and legends, PNG bytes that depend on
the data alone (no Software / date chunks), and the hemisphere sampling the panels show."""

from __future__ import annotations

import struct

import numpy as np

from sgpipe.fit.plot import (error_curves_figure, hemisphere_image, save_png,
                             slice_panels_figure)

SERIES = [("vMF mixture, view θ = 0°", [1, 2, 3], [0.3, 0.1, 0.05]),
          ("NDF SG fit (Wang09)", [1, 2, 3], [0.02, 0.008, 0.004])]


def _chunks(png: bytes) -> list[bytes]:
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    out, i = [], 8
    while i < len(png):
        n, kind = struct.unpack(">I4s", png[i:i + 8])
        out.append(kind)
        i += 12 + n
    return out


def _pixels(path):
    from PIL import Image
    return np.asarray(Image.open(path).convert("RGB"), float)


def test_error_curves_have_labelled_axes_legend_and_log_scale():
    fig = error_curves_figure(SERIES, title="shiny")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "lobes" and ax.get_ylabel() == "relative L2 error"
    assert ax.get_yscale() == "log"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [s[0] for s in SERIES]
    assert list(ax.get_xticks()) == [1, 2, 3]
    # the plotted data are the series' (non-positive errors dropped for the log axis)
    fig = error_curves_figure([("a", [1, 2, 3], [0.5, 0.0, 0.1])])
    x, y = fig.axes[0].get_lines()[0].get_data()
    assert list(x) == [1, 3] and list(y) == [0.5, 0.1]


def test_same_data_same_bytes_other_data_other_bytes(tmp_path):
    a, b, c = tmp_path / "a.png", tmp_path / "b.png", tmp_path / "c.png"
    save_png(error_curves_figure(SERIES), a)
    save_png(error_curves_figure(SERIES), b)
    save_png(error_curves_figure([(SERIES[0][0], [1, 2, 3], [0.3, 0.2, 0.05])]), c)
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes() != c.read_bytes()
    # no text chunks (matplotlib's version as Software, dates) that would vary between installs
    assert set(_chunks(a.read_bytes())) <= {b"IHDR", b"pHYs", b"IDAT", b"IEND"}
    img = _pixels(a)
    assert img.shape[0] > 200 and img.shape[1] > 300 and img.std() > 10   # a drawn plot


def test_slice_panels_show_slice_fit_and_difference(tmp_path):
    f = hemisphere_image(lambda d: np.exp(20 * (d[:, 2] - 1)), 32)
    g = 0.9 * f
    fig = slice_panels_figure([(f, g), (f, f)], ["view θ = 0°", "view θ = 45°"])
    axes = fig.axes[:6]                    # the colour bars come after the panels
    assert len(axes) == 6
    assert [ax.get_title().split("\n")[1] for ax in axes[:3]] == [
        "BRDF × cos slice", "vMF mixture fit", "|slice − fit|"]
    assert all(ax.get_xlabel() == "x (tangent)" for ax in axes)
    assert "view θ = 45°" in axes[3].get_title()
    diff = axes[2].get_images()[0].get_array()
    np.testing.assert_allclose(diff, 0.1 * f / f.max(), atol=1e-12)
    assert np.all(axes[5].get_images()[0].get_array() == 0)
    p1, p2 = tmp_path / "1.png", tmp_path / "2.png"
    save_png(fig, p1)
    save_png(slice_panels_figure([(f, g), (f, f)], ["view θ = 0°", "view θ = 45°"]), p2)
    assert p1.read_bytes() == p2.read_bytes()


def test_hemisphere_image_maps_pixels_to_directions():
    img = hemisphere_image(lambda d: d[:, 0] + 10 * d[:, 1], 8)
    c = (np.arange(8) + 0.5) / 8 * 2 - 1
    assert np.isclose(img[0, 3], c[3] - 10 * c[0])      # top row: y = −c[0] > 0 (up is +y)
    assert np.isclose(img[2, 5], c[5] - 10 * c[2])
    assert img[0, 0] == 0.0                            # outside the unit disk
