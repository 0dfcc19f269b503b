"""render/ contract: method images and the G-buffer, writer → reader, malformed files."""
import numpy as np
import pytest

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import render as art
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, write_npz

RNG = np.random.default_rng(2)


def _gbuffer(h=3, w=4):
    return {"hit": RNG.uniform(size=(h, w)) > 0.5, "position": RNG.normal(size=(h, w, 3)),
            "normal": RNG.normal(size=(h, w, 3)), "tangent": RNG.normal(size=(h, w, 3)),
            "uv": RNG.uniform(size=(h, w, 2)), "object_id": RNG.integers(-1, 2, (h, w)),
            "triangle_id": RNG.integers(-1, 9, (h, w)), "barycentrics": RNG.uniform(size=(h, w, 2))}


def test_image_round_trip(tmp_path):
    img = RNG.uniform(size=(3, 4, 3)).astype(np.float32)
    art.write_image(FolderSink(tmp_path), "reference", img, spp=16)
    np.testing.assert_array_equal(art.read_image(tmp_path, "reference"), img)
    _, meta = read_exr(tmp_path / "reference.exr", with_metadata=True)
    assert meta == {"method": "reference", "spp": 16}
    assert (tmp_path / art.image_name("reference", "png")).is_file()
    with pytest.raises(BadInput) as e:
        art.read_image(tmp_path, "sg")
    assert e.value.key == "render.methods.sg" and e.value.file == str(tmp_path / "sg.exr")


def test_gbuffer_round_trip_and_shapes(tmp_path):
    g = _gbuffer()
    art.write_gbuffer(FolderSink(tmp_path), g)
    got = art.read_gbuffer(tmp_path)
    assert got.hit.dtype == np.bool_ and got.triangle_id.dtype == np.int32
    np.testing.assert_array_equal(got.position, np.float32(g["position"]))
    np.testing.assert_array_equal(got.object_id, g["object_id"])
    g["uv"] = g["uv"][:, :3]
    write_npz(tmp_path / art.GBUFFER, g)
    with pytest.raises(BadInput, match=r"uv has shape \(3, 3, 2\)"):
        art.read_gbuffer(tmp_path)
