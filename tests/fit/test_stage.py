"""`sgpipe fit` through the CLI: artifact contract (docs/ARTIFACTS.md fit/), skip/identity,
and bad input (exit 2, one line naming file and key, nothing written)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from sgpipe.artifacts import fit as contract
from sgpipe.brdf import write_merl
from sgpipe.cli import main
from sgpipe.io import read_exr, read_npz

FAST_VIEW = {"theta_count": 3, "samples": 512, "lobes": 4, "anisotropic_lobes": 0,
             "report_lobes": 2,
             "report_views_deg": [0.0, 45.0], "iterations": 30}


def _config(tmp_path, materials, **fit_extra):
    cfg = {"name": "t", "fit": {"materials": materials, "view_gmm": dict(FAST_VIEW),
                                "ndf_sg": {"report_lobes": 2}, **fit_extra}}
    path = tmp_path / "fit.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def _run(args):
    with pytest.raises(SystemExit) as e:
        main(args)
    return e.value.code


def test_fit_writes_the_contract(tmp_path, capsys):
    cfg = _config(tmp_path, [
        {"name": "ward", "model": "ward", "params": {"alpha": 0.1, "kd": 0.2, "ks": 0.6}},
        {"name": "brushed", "model": "ggx", "params": {"alpha_u": 0.1, "alpha_v": 0.3}},
        {"name": "chalk", "model": "lambert", "params": {"kd": 0.5}}])
    out = tmp_path / "out"
    overrides = ["--set", "fit.view_gmm.phi_count=2"]
    assert _run(["fit", str(cfg), "--out", str(out)] + overrides) == 0
    fit = out / "fit"
    assert json.loads((fit / "materials.json").read_text())["materials"] == [
        "ward", "brushed", "chalk"]
    mf = read_npz(fit / "ward" / "microfacet.npz")
    assert mf["kd"].dtype == np.float32 and mf["kd"].shape == (3,)
    assert mf["shadowing"].item() == 5 and mf["fresnel"].item() == 0
    assert mf["model"].item() == "ward"
    sg = read_npz(fit / "ward" / "ndf_sg.npz", required=("axis", "sharpness", "amplitude"))
    # Ward α 0.1: one lobe near the analytic λ = 2/α² = 200 (the LM lobe: the analytic one
    # misses the tail target, ndf_sg.auto_ndf_sg)
    assert sg["axis"].shape == (1, 3) and sg["sharpness"][0] == pytest.approx(200.0, rel=0.03)
    assert sg["method"].item() == "lm"
    aniso = read_npz(fit / "brushed" / "ndf_sg.npz")
    assert aniso["axis"].shape == (8, 3) and aniso["method"].item() == "lbfgsb"
    assert read_npz(fit / "chalk" / "ndf_sg.npz")["axis"].shape == (0, 3)
    for name, n_phi in (("ward", 2), ("brushed", 2), ("chalk", 2)):
        g = read_npz(fit / name / "view_gmm.npz")
        j = 3 * n_phi
        assert g["alpha"].shape == (j, 4, 3) and g["alpha"].dtype == np.float32
        assert g["mu"].shape == (j, 4, 3) and g["kappa"].shape == (j, 4)
        assert g["view_dirs"].shape == (j, 3) and g["rel_l2"].shape == (j,)
        tex, meta = read_exr(fit / name / "view_gmm.exr", with_metadata=True)
        assert tex.shape == (3, n_phi * 4, 6) and int(meta["lobes"]) == 4
        np.testing.assert_array_equal(tex.reshape(j, 4, 6)[..., :3], g["alpha"])
        np.testing.assert_array_equal(tex.reshape(j, 4, 6)[..., 5], g["mu_theta"])
        for f in ("report.json", "error_vs_lobes.png", "slices.png", "view_gmm.png"):
            assert (fit / name / f).is_file()
    assert read_npz(fit / "chalk" / "view_gmm.npz")["includes_diffuse"].item() == 1
    # the renderer's readers accept what the stage wrote
    assert contract.read_materials_index(fit) == ["ward", "brushed", "chalk"]
    assert contract.read_microfacet(fit / "ward", "ward").shadowing == 5
    assert contract.read_ndf_sg(fit / "brushed", "brushed").axis.shape == (8, 3)
    assert contract.read_view_gmm(fit / "brushed", "brushed")["kappa"].shape == (6, 4)
    rep = json.loads((fit / "ward" / "report.json").read_text())
    assert len(rep["view_gmm"]["curve"]["rel_l2_mean"]) == 2
    assert "independent_mean" in rep["view_gmm"]["interpolation"]
    man = json.loads((fit / "manifest.json").read_text())
    assert "ward" in man["report"]
    first = {p.name: p.read_bytes() for p in (fit / "ward").iterdir()}
    assert _run(["fit", str(cfg), "--out", str(out)] + overrides) == 0
    assert "up to date" in capsys.readouterr().err
    assert _run(["fit", str(cfg), "--out", str(out), "--force"] + overrides) == 0
    assert {p.name: p.read_bytes() for p in (fit / "ward").iterdir()} == first


def test_merl_material(tmp_path):
    from sgpipe.brdf import make_brdf, synthesize_merl
    merl = tmp_path / "m.binary"
    write_merl(merl, synthesize_merl(make_brdf("ggx", {"alpha": 0.2, "kd": 0.1, "fresnel":
                                                        "dielectric", "eta": 1.33})))
    cfg = _config(tmp_path, [{"name": "m", "model": "merl", "merl_file": "m.binary"}])
    assert _run(["fit", str(cfg), "--out", str(tmp_path / "o")]) == 0
    tab = read_npz(tmp_path / "o" / "fit" / "m" / "tabulated.npz")
    assert tab["shadow_pca_basis"].shape == (8, 90) and tab["ndf_table"].shape == (90,)
    sg = read_npz(tmp_path / "o" / "fit" / "m" / "ndf_sg.npz")
    assert sg["method"].item() == "lm" and sg["axis"].shape == (3, 3)   # GGX tails: 3 lobes
    assert np.all(np.diff(sg["sharpness"]) > 0)
    assert read_npz(tmp_path / "o" / "fit" / "m" / "microfacet.npz")["shadowing"].item() == 7


@pytest.mark.parametrize("material,key,words", [
    ({"name": "a", "model": "phong_2000"}, "fit.materials.0.model", "unknown BRDF model"),
    ({"name": "a", "model": "ggx", "params": {"alpha": -0.2}}, "fit.materials.0.params.alpha",
     ">"),
    ({"name": "a", "model": "ward", "params": {"alpha": 1.7}}, "fit.materials.0.params.alpha",
     "<= 1"),
    ({"name": "a", "model": "ggx", "params": {"alpah": 0.2}}, "fit.materials.0.params.alpah",
     "unknown parameter"),
    ({"name": "a", "model": "blinn_phong", "params": {"exponent": 10, "kd": 1.0, "ks": 1.0}},
     "fit.materials.0.params", "energy"),
    ({"name": "a/b", "model": "lambert"}, "fit.materials.0.name", "letters"),
])
def test_bad_input_exits_2_and_writes_nothing(tmp_path, capsys, material, key, words):
    cfg = _config(tmp_path, [material])
    out = tmp_path / "out"
    assert _run(["fit", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and key in err[0] and words in err[0] and str(cfg) in err[0]
    assert not (out / "fit").exists()


def test_wrong_size_merl_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.binary"
    bad.write_bytes(np.array([90, 90, 180], "<i4").tobytes() + b"\0" * 4000)
    cfg = _config(tmp_path, [{"name": "m", "model": "merl", "merl_file": "bad.binary"}])
    assert _run(["fit", str(cfg), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "fit.materials.0.merl_file" in err and "truncated" in err and "bad.binary" in err
    assert not (tmp_path / "out" / "fit").exists()
