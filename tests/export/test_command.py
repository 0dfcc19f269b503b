"""`sgpipe export` through the real CLI: the files, the glTF loaded back with pygltflib,
byte-identical reruns, bad input (one line, exit 2, nothing written)."""

import json
import shutil

import numpy as np
import pygltflib as gl
import pytest

from sgpipe.export import dds, gltf, ktx2
from sgpipe.export.bundle import MARKER

from .export_helpers import run_cli


class Result:
    def __init__(self, returncode, stderr):
        self.returncode, self.stderr = returncode, stderr


@pytest.fixture
def cli(capsys):
    """`sgpipe ARGS` in this process (sgpipe.cli.main: the same error handling as the
    console script, without a new interpreter's imports)."""
    from sgpipe.cli import main

    def call(*args):
        capsys.readouterr()
        try:
            main([str(a) for a in args])
            code = 0
        except SystemExit as e:
            code = e.code
        return Result(code, capsys.readouterr().err)
    return call


@pytest.fixture(scope="module")
def exported(tiny_run, tmp_path_factory):
    """The real console entry point, once."""
    out = tmp_path_factory.mktemp("exp") / "export"
    r = run_cli("export", tiny_run["dir"], "--out", out)
    assert r.returncode == 0, r.stderr
    return out


def _accessor(doc, blob, i):
    acc = doc.accessors[i]
    view = doc.bufferViews[acc.bufferView]
    width = {gl.SCALAR: 1, gl.VEC2: 2, gl.VEC3: 3, gl.VEC4: 4}[acc.type]
    dtype = {gl.UNSIGNED_INT: np.uint32, gl.UNSIGNED_SHORT: np.uint16,
             gl.UNSIGNED_BYTE: np.uint8, gl.FLOAT: np.float32}[acc.componentType]
    return np.frombuffer(blob, dtype, acc.count * width, view.byteOffset + (acc.byteOffset or 0)
                         ).reshape(acc.count, width)


def test_files_and_metadata(exported):
    names = sorted(p.relative_to(exported).as_posix() for p in exported.rglob("*") if p.is_file())
    assert {"environment.ktx2", "environment.dds", "irradiance_sh9.json", "scene.gltf",
            "scene.bin", "export.json", MARKER} <= set(names)
    k = ktx2.read_ktx2((exported / "environment.ktx2").read_bytes())
    assert (k["header"]["width"], k["header"]["level_count"]) == (32, 6)
    assert dict(k["kvd"])["sgpipe.roughnessMapping"].startswith(
        b"roughness = level / (levelCount - 1)")
    d = dds.read_dds((exported / "environment.dds").read_bytes())
    for a, b in zip(k["levels"], d["levels"]):               # the same texels in both files
        np.testing.assert_array_equal(a, b)
    info = json.loads((exported / "export.json").read_text())
    assert [lv["roughness"] for lv in info["cubemap_levels"]] == pytest.approx(
        [0, 0.2, 0.4, 0.6, 0.8, 1.0])


def test_gltf_loads_back_with_its_accessors(exported, tiny_run):
    doc = gl.GLTF2().load(str(exported / "scene.gltf"))
    blob = (exported / doc.buffers[0].uri).read_bytes()
    assert len(blob) == doc.buffers[0].byteLength
    obj = tiny_run["object"]
    (mesh,) = doc.meshes
    prim = mesh.primitives[0]
    attrs = prim.attributes
    pos = _accessor(doc, blob, attrs.POSITION)
    np.testing.assert_allclose(pos, obj["positions"], rtol=1e-7)
    assert doc.accessors[attrs.POSITION].min == pytest.approx(pos.min(0).tolist())
    np.testing.assert_array_equal(_accessor(doc, blob, prim.indices).reshape(-1, 3), obj["faces"])
    tan = _accessor(doc, blob, attrs.TANGENT)
    np.testing.assert_allclose(tan[:, :3], obj["tangents"], rtol=1e-6)
    assert np.all(tan[:, 3] == 1.0)
    uv = _accessor(doc, blob, attrs.TEXCOORD_0)
    np.testing.assert_allclose(uv, np.c_[obj["uvs"][:, 0], 1 - obj["uvs"][:, 1]], rtol=1e-6)
    ext = mesh.extras["sgpipe_ssdf"]
    assert ext["attributes"] == ["_SSDF_PCA0", "_SSDF_PCA1"] and ext["terms"] == 6
    coeffs = np.concatenate([_accessor(doc, blob, getattr(attrs, a)) for a in ext["attributes"]], 1)
    assert all(doc.accessors[getattr(attrs, a)].type == gl.VEC4 for a in ext["attributes"])
    np.testing.assert_allclose(coeffs[:, :6], obj["coeffs"], rtol=1e-6)
    assert np.all(coeffs[:, 6:] == 0)
    np.testing.assert_allclose(_accessor(doc, blob, ext["mean_accessor"]).reshape(4, 4),
                               obj["mean"], rtol=1e-6)
    np.testing.assert_allclose(_accessor(doc, blob, ext["basis_accessor"]).reshape(6, 4, 4),
                               obj["basis"], rtol=1e-6)


def test_gltf_image_based_light(exported):
    doc = gl.GLTF2().load(str(exported / "scene.gltf"))
    assert doc.extensionsUsed == [gltf.EXTENSION]
    (light,) = doc.extensions[gltf.EXTENSION]["lights"]
    assert doc.scenes[doc.scene].extensions[gltf.EXTENSION] == {"light": 0}
    sh = json.loads((exported / "irradiance_sh9.json").read_text())
    # the default glTF orientation: the light's cube frame shows at e what the world shows at
    # M·e; its rotation turns e to M·e and its irradiance is the world's read at M·e
    from scipy.spatial.transform import Rotation
    from sgpipe.export.orientation import GLTF_TO_MAP
    from sgpipe.export.sh9 import sh9_irradiance
    e = np.random.default_rng(3).normal(size=(40, 3))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    np.testing.assert_allclose(Rotation.from_quat(light["rotation"]).apply(e), e @ GLTF_TO_MAP.T,
                               atol=1e-12)
    np.testing.assert_allclose(sh9_irradiance(light["irradianceCoefficients"], e),
                               sh9_irradiance(sh["irradiance"], e @ GLTF_TO_MAP.T), rtol=1e-10)
    np.testing.assert_allclose(light["extras"]["sgpipe_world_irradiance"], sh["irradiance"],
                               rtol=1e-10, atol=1e-12)
    assert light["specularImageSize"] == 32
    ids = light["specularImages"]
    assert [len(r) for r in ids] == [6, 6]                      # 32 and 16: down to 16²
    info = json.loads((exported / "export.json").read_text())
    assert [lv["roughness"] for lv in info["gltf"]["ibl_levels"]] == [0.0, 1.0]
    import OpenImageIO as oiio
    for m, row in enumerate(ids):
        for f, i in enumerate(row):
            img = doc.images[i]
            assert img.mimeType == "image/png" and img.uri == f"ibl/specular_{m:02d}_{f}.png"
            inp = oiio.ImageInput.open(str(exported / img.uri))
            px = inp.read_image(0, 0, 0, 4, "uint8")
            inp.close()
            assert px.shape == (32 >> m, 32 >> m, 4)            # RGBD: four channels


def test_rgbd_round_trip():
    rng = np.random.default_rng(1)
    x = rng.lognormal(0.0, 2.0, size=(5000, 3)).clip(max=250.0)
    back = gltf.rgbd_decode(gltf.rgbd_encode(x))
    peak = x.max(1, keepdims=True)
    assert np.all(np.abs(back - x) <= 0.03 * peak + 2e-3)       # 8-bit steps of the brightest


def test_same_input_same_bytes(exported, tiny_run, tmp_path, cli):
    again = tmp_path / "again"
    assert cli("export", tiny_run["dir"], "--out", again).returncode == 0
    for p in exported.rglob("*"):
        if p.is_file():
            assert (again / p.relative_to(exported)).read_bytes() == p.read_bytes(), p


@pytest.mark.parametrize("fmt,vk", [("b10g11r11", 122), ("rgba32f", 109)])
def test_format_option(tiny_run, tmp_path, cli, fmt, vk):
    r = cli("export", tiny_run["dir"], "--out", tmp_path / "e", "--format", fmt,
                "--size", "16")
    assert r.returncode == 0, r.stderr
    k = ktx2.read_ktx2((tmp_path / "e" / "environment.ktx2").read_bytes())
    assert (k["header"]["vk_format"], k["header"]["width"], len(k["levels"])) == (vk, 16, 5)


def _copy_run(tiny_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(tiny_run["dir"], run)
    return run


@pytest.mark.parametrize("victim,key", [("envmap/light_sh.npz", "envmap"),
                                        ("envmap/pyramid/raw.exr", "envmap"),
                                        ("envmap/pyramid.npz", "envmap"),
                                        ("visibility/blob/ssdf_pca.npz", "visibility.blob")])
def test_missing_artifact_is_one_line_exit_2_nothing_written(tiny_run, tmp_path, victim, key,
                                                             cli):
    run = _copy_run(tiny_run, tmp_path)
    (run / victim).unlink()
    out = tmp_path / "deep" / "export"
    r = cli("export", run, "--out", out)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and victim.split("/")[-1] in lines[0] and key in lines[0], lines
    assert not (tmp_path / "deep").exists()


def test_unknown_options_are_bad_input(tiny_run, tmp_path, cli):
    for args, key in ((["--format", "rgb9e5"], "--format"), (["--size", "12"], "--size"),
                      (["--only", "ktx"], "--only"), (["--prefilter", "mc"], "--prefilter"),
                      (["--orientation", "x"], "--orientation")):
        r = cli("export", tiny_run["dir"], "--out", tmp_path / "x", *args)
        assert r.returncode == 2 and key in r.stderr and len(r.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "x").exists() and list(tmp_path.iterdir()) == []


def test_failure_keeps_the_previous_export(tiny_run, tmp_path, cli):
    run = _copy_run(tiny_run, tmp_path)
    out = tmp_path / "export"
    assert cli("export", run, "--out", out).returncode == 0
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    np.savez(run / "visibility/blob/ssdf_pca.npz", mean=np.zeros((4, 4)),
             basis=np.zeros((6, 4, 4)), coeffs=np.zeros((5, 6)))     # 5 vertices, not 6
    r = cli("export", run, "--out", out)
    assert r.returncode == 2 and "vertices" in r.stderr
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert sorted(q.name for q in tmp_path.iterdir()) == ["export", "run"]   # no staging left


def test_foreign_folder_is_not_replaced(tiny_run, tmp_path, cli):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    r = cli("export", tiny_run["dir"], "--out", tmp_path / "mine")
    assert r.returncode == 2 and "--out" in r.stderr
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep"
