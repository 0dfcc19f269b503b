"""`sgpipe export` options: the panorama as the prefilter's source (found through the envmap
stage's manifest), --size above the envmap's cube, --only, --prefilter, and their errors."""

import json
import shutil

import numpy as np
import pytest

from sgpipe.envmap.maps import latlong_to_cubemap
from sgpipe.errors import BadInput
from sgpipe.export import ktx2
from sgpipe.export.bundle import write_export
from sgpipe.export.tree_prefilter import point_samples
from sgpipe.io import write_exr
from sgpipe.io.atomic import file_hash

from .export_helpers import write_envmap
from .test_ggx_tree import lamps_and_sun

N = 16


@pytest.fixture(scope="module")
def pano_run(tmp_path_factory):
    """A run folder whose envmap/ was made from a panorama the manifest names (as the envmap
    stage writes it), at a 16² cube."""
    root = tmp_path_factory.mktemp("pano")
    pano = lamps_and_sun(64)
    path = root / "lamps.exr"
    write_exr(path, pano.astype(np.float32))
    pano = pano.astype(np.float32).astype(np.float64)
    write_envmap(root / "run", latlong_to_cubemap(pano, N))
    (root / "run" / "envmap" / "manifest.json").write_text(json.dumps(
        {"stage": "envmap", "inputs": {str(path.resolve()): file_hash(path)}}))
    return {"dir": root / "run", "pano": pano, "path": path}


def _levels(folder):
    return ktx2.read_ktx2((folder / "environment.ktx2").read_bytes())["levels"]


def test_size_above_the_cube_prefilters_the_panorama(pano_run, tmp_path):
    out = write_export(pano_run["dir"], tmp_path / "e", size=4 * N, only="ktx2",
                       fmt="rgba32f", orientation="sgpipe")
    assert sorted(p.name for p in out.iterdir()) == [".sgpipe-export", "environment.ktx2",
                                                     "export.json"]
    levels = _levels(out)
    assert [lv.shape[1] for lv in levels] == [64, 32, 16, 8, 4, 2, 1]
    np.testing.assert_allclose(levels[0][..., :3], point_samples(pano_run["pano"], 64),
                               rtol=1e-6)
    info = json.loads((out / "export.json").read_text())
    assert info["products"] == ["ktx2"] and "gltf" not in info and "sh9" not in info
    assert info["cubemap"]["prefilter"] == "tree" and "lamps.exr" in info["cubemap"]["source"]
    assert str(pano_run["path"].resolve()) in info["run_dir_inputs"]


def test_only_writes_the_named_products(pano_run, tmp_path):
    out = write_export(pano_run["dir"], tmp_path / "e", only="sh9,dds")
    names = sorted(p.name for p in out.iterdir())
    assert names == [".sgpipe-export", "environment.dds", "export.json", "irradiance_sh9.json"]


def test_a_changed_panorama_falls_back_to_the_stage_cube(pano_run, tmp_path, capsys):
    run = tmp_path / "run"
    shutil.copytree(pano_run["dir"], run)
    man = run / "envmap" / "manifest.json"
    doc = json.loads(man.read_text())
    doc["inputs"] = {k: "0" * 64 for k in doc["inputs"]}
    man.write_text(json.dumps(doc))
    out = write_export(run, tmp_path / "e", only="ktx2")
    assert "not found or changed; --environment PATH names it" in capsys.readouterr().out
    info = json.loads((out / "export.json").read_text())
    assert info["cubemap"]["source"].startswith(f"the envmap stage's {N}² cube")
    with pytest.raises(BadInput, match="divided by a power of two"):
        write_export(run, tmp_path / "e2", size=2 * N)


def test_pyramid_prefilter_is_still_selectable(pano_run, tmp_path):
    out = write_export(pano_run["dir"], tmp_path / "e", only="ktx2", prefilter="pyramid")
    info = json.loads((out / "export.json").read_text())
    assert info["cubemap"]["prefilter"] == "pyramid"
    assert {lv["method"] for lv in info["cubemap_levels"][1:]} <= {"pyramid", "direct"}


@pytest.mark.parametrize("kw, key", [({"only": "ktx2,png"}, "--only"), ({"only": ","}, "--only"),
                                     ({"prefilter": "fast"}, "--prefilter"),
                                     ({"size": 48}, "--size"), ({"size": 4096}, "--size"),
                                     ({"orientation": "threejs"}, "--orientation")])
def test_bad_options_are_bad_input(pano_run, tmp_path, kw, key):
    with pytest.raises(BadInput) as e:
        write_export(pano_run["dir"], tmp_path / "e", **kw)
    assert e.value.key == key
    assert not (tmp_path / "e").exists()


def test_environment_option_names_the_panorama(pano_run, tmp_path):
    """A `<config>/…` manifest key (the config's folder is not recorded) that does not resolve
    from the working folder: --environment names the file, checked against the hash."""
    run = tmp_path / "run"
    shutil.copytree(pano_run["dir"], run)
    man = run / "envmap" / "manifest.json"
    doc = json.loads(man.read_text())
    digest, = doc["inputs"].values()
    doc["inputs"] = {"<config>/../elsewhere/lamps.exr": digest}
    man.write_text(json.dumps(doc))
    out = write_export(run, tmp_path / "e", only="ktx2", environment=pano_run["path"])
    info = json.loads((out / "export.json").read_text())
    assert "lamps.exr" in info["cubemap"]["source"]
    other = tmp_path / "other.exr"
    write_exr(other, np.ones((8, 16, 3), np.float32))
    with pytest.raises(BadInput, match="is not the panorama the envmap stage read") as e:
        write_export(run, tmp_path / "e2", only="ktx2", environment=other)
    assert e.value.key == "--environment"
