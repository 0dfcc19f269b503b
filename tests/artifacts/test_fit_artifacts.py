"""fit/ contract: writer → reader round trips, the view_gmm texture layout, malformed files."""
import json

import numpy as np
import pytest

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import fit as art
from sgpipe.brdf import make_brdf
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz, write_npz

RNG = np.random.default_rng(3)


def test_microfacet_round_trip(tmp_path):
    brdf = make_brdf("ggx", {"alpha_u": 0.1, "alpha_v": 0.3, "kd": 0.2, "ks": 0.5,
                             "fresnel": "schlick", "f0": 0.04})
    mf = brdf.microfacet_params()
    art.write_microfacet(FolderSink(tmp_path), "m", mf)
    got = art.read_microfacet(tmp_path / "m", "m")
    np.testing.assert_array_equal(got.kd, np.float32(mf["kd"]))
    np.testing.assert_array_equal(got.shadow_table, np.float32(mf["shadow_table"]))
    assert got.alpha_v == np.float32(0.3) and got.g_scale == np.float32(mf["g_scale"])
    assert (got.diffuse, got.fresnel, got.shadowing) == (mf["diffuse"], mf["fresnel"],
                                                         mf["shadowing"])
    z = read_npz(tmp_path / "m" / art.MICROFACET)
    assert z["diffuse"].dtype == np.int32 and z["kd"].dtype == np.float32
    assert str(z["model"]) == "ggx" and not any(k.endswith("_kind") for k in z)
    assert json.loads((tmp_path / "m" / art.MICROFACET_JSON).read_text())["model"] == "ggx"


def test_ndf_sg_and_tabulated_round_trip(tmp_path):
    sink = FolderSink(tmp_path)
    lobes = {"axis": np.tile([0.0, 0.0, 1.0], (2, 1)), "sharpness": np.array([10.0, 100.0]),
             "amplitude": np.array([0.3, 0.7]), "rel_l2": 0.01, "method": np.array("lm")}
    art.write_ndf_sg(sink, "m", lobes)
    got = art.read_ndf_sg(tmp_path / "m", "m")
    np.testing.assert_array_equal(got.sharpness, [10.0, 100.0])
    assert got.axis.shape == (2, 3) and got.amplitude[1] == np.float32(0.7)
    with pytest.raises(ValueError, match="rel_l2"):
        art.write_ndf_sg(sink, "m", {k: v for k, v in lobes.items() if k != "rel_l2"})
    empty = {"axis": np.zeros((0, 3)), "sharpness": np.zeros(0), "amplitude": np.zeros(0),
             "rel_l2": 0.0, "method": np.array("none")}
    art.write_ndf_sg(sink, "e", empty)
    assert art.read_ndf_sg(tmp_path / "e", "e").axis.shape == (0, 3)
    tab = {k: RNG.uniform(size=90) for k in ("ndf_theta_h", "ndf_table", "shadow_table",
                                             "shadow_pca_mean", "shadow_pca_coeffs")}
    tab.update(shadow_pca_basis=RNG.uniform(size=(8, 90)), eta=1.33)
    art.write_tabulated(sink, "m", tab)
    np.testing.assert_array_equal(art.read_tabulated(tmp_path / "m", "m")["ndf_table"],
                                  np.float32(tab["ndf_table"]))


def _gmm(n_t=3, n_p=2, k=4):
    j = n_t * n_p
    return {"view_theta": np.linspace(0, 1, n_t), "view_phi": np.arange(n_p) * np.pi,
            "view_dirs": RNG.normal(size=(j, 3)), "alpha": RNG.uniform(size=(j, k, 3)),
            "kappa": RNG.uniform(1, 50, (j, k)), "mu": RNG.normal(size=(j, k, 3)),
            "mu_theta": RNG.uniform(0, 1, (j, k)), "mu_phi": RNG.uniform(-3, 3, (j, k)),
            "albedo": RNG.uniform(size=(j, 3)), "rel_l2": RNG.uniform(size=j),
            "includes_diffuse": True, "coherent": False}


def test_view_gmm_round_trip_and_texture_layout(tmp_path):
    g = _gmm()
    art.write_view_gmm(FolderSink(tmp_path), "m", g, view_theta_max=1.0)
    got = art.read_view_gmm(tmp_path / "m", "m")
    np.testing.assert_array_equal(got["alpha"], np.float32(g["alpha"]))
    assert got["includes_diffuse"] == 1 and got["coherent"] == 0
    tex, meta = read_exr(tmp_path / "m" / art.VIEW_GMM_TEXTURE, with_metadata=True)
    assert tex.shape == (3, 2 * 4, 6)
    assert (meta["lobes"], meta["theta_count"], meta["phi_count"]) == (4, 3, 2)
    t, p, k = 2, 1, 3
    j = t * 2 + p
    np.testing.assert_array_equal(tex[t, p * 4 + k], np.float32(
        [*g["alpha"][j, k], g["kappa"][j, k], g["mu_phi"][j, k], g["mu_theta"][j, k]]))


def test_view_gmm_reader_checks_shapes(tmp_path):
    g = {k: np.asarray(v) for k, v in _gmm().items()}
    g["kappa"] = g["kappa"][:, :3]
    write_npz(tmp_path / art.VIEW_GMM, g)
    with pytest.raises(BadInput) as e:
        art.read_view_gmm(tmp_path, "m")
    assert e.value.file == str(tmp_path / art.VIEW_GMM) and e.value.key == "fit.materials.m"
    assert "kappa has shape (6, 3)" in e.value.message


def test_malformed_microfacet_and_ndf_files(tmp_path):
    write_npz(tmp_path / art.MICROFACET, {"kd": np.ones(2), "ks": np.ones(3), "g_scale": 1.0,
                                          "diffuse": 0, "fresnel": 0, "shadowing": 0})
    with pytest.raises(BadInput) as e:
        art.read_microfacet(tmp_path, "m")
    assert "kd has shape (2,), expected (3)" in e.value.one_line()
    write_npz(tmp_path / art.NDF_SG, {"axis": np.zeros((2, 3)), "sharpness": np.ones(2),
                                      "amplitude": np.ones(3)})
    with pytest.raises(BadInput, match="amplitude"):
        art.read_ndf_sg(tmp_path, "m")
    p = tmp_path / art.NDF_SG
    p.write_bytes(p.read_bytes()[:40])
    with pytest.raises(BadInput) as e:
        art.read_ndf_sg(tmp_path, "m")
    assert e.value.file == str(p) and "\n" not in e.value.one_line()


def test_materials_index_round_trip(tmp_path):
    art.write_materials_index(FolderSink(tmp_path), ["a", "b"])
    assert art.read_materials_index(tmp_path) == ["a", "b"]
    (tmp_path / art.MATERIALS_INDEX).write_text('{"materials": "a"}')
    with pytest.raises(BadInput, match="list of names"):
        art.read_materials_index(tmp_path)
    (tmp_path / art.MATERIALS_INDEX).write_text('{"materials": [')
    with pytest.raises(BadInput) as e:
        art.read_materials_index(tmp_path)
    assert e.value.key == "fit.materials" and "\n" not in e.value.one_line()
