"""Normal-map reading: the three formats decode to the renderer's normals; bad maps are one
BadInput line naming the file and key."""

import numpy as np
import pytest

from sgpipe.errors import BadInput
from sgpipe.normalmap.read import decode_normals, read_normal_map

from .helpers import tilted_normals, write_image


@pytest.mark.parametrize("fmt,ext,tol", [("uint8", "png", 2.5 / 255), ("uint16", "png", 4e-5),
                                         ("float", "exr", 1e-6)])
def test_formats_decode_to_unit_normals(tmp_path, fmt, ext, tol):
    n = tilted_normals(16)
    p = tmp_path / f"n.{ext}"
    write_image(p, n * 0.5 + 0.5, fmt)
    got = read_normal_map(p, key="k")
    assert got.shape == (16, 16, 3)
    np.testing.assert_allclose(np.linalg.norm(got, axis=-1), 1.0, atol=1e-12)
    # quantisation error of (n+1)/2 is ≤ half a step per channel, doubled by 2c − 1
    assert np.abs(got - n).max() < 2 * tol
    # row 0 stays the top row (no flip): the texel order of the file
    assert np.allclose(got[0, 3], n[0, 3], atol=2 * tol)


def test_four_channels_ignore_alpha(tmp_path):
    n = tilted_normals(8)
    rgba = np.concatenate([n * 0.5 + 0.5, np.zeros((8, 8, 1))], -1)
    write_image(tmp_path / "a.png", rgba, "uint16")
    np.testing.assert_allclose(read_normal_map(tmp_path / "a.png"), n, atol=1e-4)


def test_decode_matches_renderer_floor_on_z():
    # normal_from_map: n = 2c − 1, n.z = max(n.z, 1e-3), normalise
    c = np.array([[[1.0, 0.5, 0.25]]])
    got = decode_normals(c)[0, 0]
    want = np.array([1.0, 0.0, 1e-3]) / np.linalg.norm([1.0, 0.0, 1e-3])
    np.testing.assert_allclose(got, want, rtol=1e-12)


def _bad(tmp_path, img, fmt="float", ext="exr", match=""):
    p = tmp_path / f"bad.{ext}"
    write_image(p, img, fmt)
    with pytest.raises(BadInput, match=match) as e:
        read_normal_map(p, key="scene.objects.0.normal_map")
    line = e.value.one_line()
    assert str(p) in line and "scene.objects.0.normal_map" in line and "\n" not in line


def test_bad_channel_count(tmp_path):
    _bad(tmp_path, np.full((8, 8, 2), 0.5), match="2 channels")
    _bad(tmp_path, np.full((8, 8, 1), 0.5), "uint8", "png", match="1 channel")


def test_bad_size(tmp_path):
    _bad(tmp_path, np.full((8, 12, 3), 0.7), match="power-of-two")
    _bad(tmp_path, np.full((12, 12, 3), 0.7), "uint8", "png", match="power-of-two")


def test_zero_length_and_nonfinite(tmp_path):
    img = tilted_normals(8) * 0.5 + 0.5
    img[3, 5] = 0.5
    _bad(tmp_path, img, "uint16", "png", match="zero-length.*row 3, column 5")
    img = tilted_normals(8) * 0.5 + 0.5
    img[2, 1, 0] = np.nan
    _bad(tmp_path, img, match="NaN/Inf")


def test_signed_exr_is_refused(tmp_path):
    _bad(tmp_path, tilted_normals(8), match="signed normals")


def test_unsupported_and_missing(tmp_path):
    with pytest.raises(BadInput, match="unsupported"):
        read_normal_map(tmp_path / "x.jpg", key="k")
    with pytest.raises(BadInput, match="not found"):
        read_normal_map(tmp_path / "x.png", key="k")
