"""Artifact store: EXR/NPZ/PNG round trips, validation, determinism, atomicity."""

import time

import numpy as np
import pytest

from sgpipe.errors import BadInput
from sgpipe.io import atomic_path, file_hash, read_exr, read_npz, write_exr, write_npz, write_png


def _img(h=9, w=17, c=3, seed=0):
    return np.random.default_rng(seed).random((h, w, c), dtype=np.float32) * 100


@pytest.mark.parametrize("c", [1, 3, 4])
def test_exr_float_roundtrip_is_exact(tmp_path, c):
    img = _img(c=c)
    write_exr(tmp_path / "a.exr", img)
    back = read_exr(tmp_path / "a.exr")
    assert back.shape == img.shape
    assert np.array_equal(back, img)


def test_exr_half_roundtrip_within_half_precision(tmp_path):
    img = _img()
    write_exr(tmp_path / "a.exr", img, half=True)
    back = read_exr(tmp_path / "a.exr")
    assert np.allclose(back, img, rtol=1e-3)
    assert not np.array_equal(back, img)  # really stored as half


def test_exr_metadata_roundtrip(tmp_path):
    write_exr(tmp_path / "a.exr", _img(), metadata={"stage": "envmap", "lambda": 12.5, "level": 3})
    _, meta = read_exr(tmp_path / "a.exr", with_metadata=True)
    assert meta["stage"] == "envmap" and meta["level"] == 3
    assert meta["lambda"] == pytest.approx(12.5)


def test_exr_bytes_do_not_depend_on_wall_clock(tmp_path):
    img = _img()
    write_exr(tmp_path / "a.exr", img, metadata={"x": 1})
    h1 = file_hash(tmp_path / "a.exr")
    time.sleep(1.1)  # OpenEXR would otherwise stamp DateTime with the current second
    write_exr(tmp_path / "a.exr", img, metadata={"x": 1})
    assert file_hash(tmp_path / "a.exr") == h1


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_exr_nonfinite_is_bad_input(tmp_path, bad):
    img = _img()
    img[2, 3, 1] = bad
    write_exr(tmp_path / "a.exr", img)
    with pytest.raises(BadInput, match="NaN/Inf in 1 pixels"):
        read_exr(tmp_path / "a.exr", key="envmap.environment")


def test_exr_channel_count_checked(tmp_path):
    write_exr(tmp_path / "a.exr", _img(c=2))
    with pytest.raises(BadInput, match="2 channels, expected 3 or 4") as e:
        read_exr(tmp_path / "a.exr", channels=(3, 4), key="k")
    assert "a.exr" in e.value.one_line() and "k" in e.value.one_line()


def test_unreadable_and_missing_images(tmp_path):
    (tmp_path / "junk.exr").write_bytes(b"not an exr at all")
    with pytest.raises(BadInput, match="unreadable"):
        read_exr(tmp_path / "junk.exr")
    with pytest.raises(BadInput, match="not found"):
        read_exr(tmp_path / "missing.exr")


def test_npz_roundtrip_and_determinism(tmp_path):
    arrays = {"b": np.arange(10, dtype=np.int32), "a": _img(), "names": np.array(["x", "yy"]),
              "scalar": np.float32(2.5), "label": np.array("ward"), "strided": _img()[:, ::2]}
    write_npz(tmp_path / "a.npz", arrays)
    h1 = file_hash(tmp_path / "a.npz")
    time.sleep(1.1)
    write_npz(tmp_path / "a.npz", dict(reversed(list(arrays.items()))))
    assert file_hash(tmp_path / "a.npz") == h1
    back = read_npz(tmp_path / "a.npz", required=("a", "b"))
    for k in arrays:
        assert back[k].shape == np.shape(arrays[k]) and np.array_equal(back[k], arrays[k]), k
    # plain numpy reads it without pickle
    with np.load(tmp_path / "a.npz", allow_pickle=False) as z:
        assert sorted(z.files) == sorted(arrays)


def test_npz_rejects_object_arrays_and_reports_missing(tmp_path):
    with pytest.raises(TypeError):
        write_npz(tmp_path / "o.npz", {"o": np.array([{}, 1], dtype=object)})
    assert not (tmp_path / "o.npz").exists()
    write_npz(tmp_path / "a.npz", {"a": np.zeros(2)})
    with pytest.raises(BadInput, match="missing arrays"):
        read_npz(tmp_path / "a.npz", required=("a", "b"))


def test_atomic_path_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "x.bin"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_bytes(b"half")
            raise RuntimeError("boom")
    assert target.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.bin"]


def test_png_preview_tonemap(tmp_path):
    from sgpipe.io import tonemap_srgb
    x = np.array([0.0, 0.0031308, 0.5, 1.0, 7.0])
    out = tonemap_srgb(x)
    assert out.tolist() == [0, 10, 188, 255, 255]
    write_png(tmp_path / "p.png", _img() / 100)
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
