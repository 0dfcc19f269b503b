"""visibility/ contract: writer → reader round trips, eigen-images, malformed files."""
import numpy as np
import pytest

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import visibility as art
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz, write_npz

RNG = np.random.default_rng(5)


def _mesh(v=5):
    return dict(positions=RNG.normal(size=(v, 3)), normals=RNG.normal(size=(v, 3)),
                tangents=RNG.normal(size=(v, 3)), bitangents=RNG.normal(size=(v, 3)),
                faces=np.array([[0, 1, 2], [2, 3, 4]]), uvs=RNG.uniform(size=(v, 2)),
                has_uvs=True, ray_offset=1e-3)


def test_geometry_round_trip(tmp_path):
    m = _mesh()
    art.write_geometry(FolderSink(tmp_path), "obj", **m)
    g = art.read_geometry(tmp_path, "obj")
    np.testing.assert_array_equal(g.positions, np.float32(m["positions"]))
    np.testing.assert_array_equal(g.tangents, np.float32(m["tangents"]))
    np.testing.assert_array_equal(g.faces, m["faces"])
    z = read_npz(tmp_path / "obj" / art.GEOMETRY)
    assert z["faces"].dtype == np.int32 and z["has_uvs"] == 1
    assert z["ray_offset"] == np.float32(1e-3)


def test_ssdf_pca_round_trip_and_eigen_images(tmp_path):
    r, t, v = 4, 3, 5
    mean, basis = RNG.normal(size=(r, r)), RNG.normal(size=(t, r, r))
    art.write_ssdf_pca(FolderSink(tmp_path), "obj", mean=mean, basis=basis,
                       coeffs=RNG.normal(size=(v, t)), explained_variance=np.ones(t),
                       resolution=r, trace_resolution=16, max_distance=1.2)
    pca = art.read_ssdf_pca(tmp_path, "obj")
    np.testing.assert_array_equal(pca.basis, np.float32(basis))
    assert pca.coeffs.shape == (v, t) and pca.max_distance == pytest.approx(1.2)
    img, meta = read_exr(tmp_path / "obj" / art.eigen_name(2), with_metadata=True)
    np.testing.assert_array_equal(img[..., 0], np.float32(basis[2]))
    assert meta["term"] == 2 and meta["resolution"] == r and meta["object"] == "obj"
    assert read_exr(tmp_path / "obj" / art.eigen_name(None)).shape == (r, r, 1)
    assert art.eigen_name(None, "png") == "eigen/ssdf_mean.png"
    assert art.preview_name(12) == "previews/vertex_00012.png"


def test_malformed_geometry_and_pca(tmp_path):
    m = _mesh()
    m["faces"] = np.array([[0, 1, 7]])
    art.write_geometry(FolderSink(tmp_path), "obj", **m)
    with pytest.raises(BadInput) as e:
        art.read_geometry(tmp_path, "obj")
    assert e.value.file == str(tmp_path / "obj" / art.GEOMETRY)
    assert e.value.key == "visibility.obj" and "outside 0..4" in e.value.message
    write_npz(tmp_path / "obj" / art.SSDF_PCA, {"mean": np.zeros((4, 4)),
                                               "basis": np.zeros((3, 4, 4)),
                                               "coeffs": np.zeros((5, 2))})
    with pytest.raises(BadInput, match=r"coeffs has shape \(5, 2\), expected \(V, 3\)"):
        art.read_ssdf_pca(tmp_path, "obj")
    p = tmp_path / "obj" / art.SSDF_PCA
    p.write_bytes(p.read_bytes()[:100])
    with pytest.raises(BadInput) as e:
        art.read_ssdf_pca(tmp_path, "obj")
    assert e.value.file == str(p) and "\n" not in e.value.one_line()
