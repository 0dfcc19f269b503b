"""Green06 interreflection in the glTF: the RGB transfer (shadowed + interreflected) round-trips
through the buffer's `transfer_rgb` table; without interreflection nothing is added."""

import shutil

import numpy as np
import pygltflib as gl

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import transport as tr_art
from sgpipe.export.bundle import write_export
from sgpipe.transport import compact
from sgpipe.transport.views import N_VIEWS

from .test_command import _accessor


def _object(root, name, geo, indirect, seed):
    rng = np.random.default_rng(seed)
    x = len(geo["positions"])
    mu = rng.normal(size=(x, N_VIEWS, 2, 3))
    mu /= np.linalg.norm(mu, axis=-1, keepdims=True)
    packed = compact.encode(mu, rng.uniform(0.05, 0.8, (x, N_VIEWS, 2)),
                            rng.uniform(0, 3, (x, N_VIEWS, 2, 3)), 0.02, 1.0)
    sh = rng.normal(size=(x, 25))
    ind = rng.normal(scale=0.1, size=(x, 25, 3)) if indirect else None
    tr_art.write_object(FolderSink(root / "transport"), name, packed=packed, cube_resolution=8,
                        gaussians=2, sh=sh, diffuse_rgb=[0.5, 0.4, 0.3], sh_indirect=ind,
                        positions=geo["positions"], normals=geo["normals"], faces=geo["faces"])


def _export(tiny_run, tmp_path, indirect):
    run = tmp_path / "run"
    shutil.copytree(tiny_run["dir"], run)
    obj = tiny_run["object"]
    _object(run, "blob", obj, indirect, 0)                        # shares the visibility mesh
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    _object(run, "tet", dict(positions=pos + 2, normals=pos - 0.25, faces=np.array(
        [[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])), indirect, 1)
    out = write_export(run, tmp_path / "export")
    return run, gl.GLTF2().load(str(out / "scene.gltf")), (out / "scene.bin").read_bytes()


def test_rgb_transfer_round_trips(tiny_run, tmp_path):
    """Decoded with the documented recipe (entry x·25 + k, RGB) the table equals
    read_sh_transfer_rgb's shadowed + interreflected transfer in float32; the attributes keep
    the shadowed part alone."""
    run, doc, blob = _export(tiny_run, tmp_path, indirect=True)
    assert [m.name for m in doc.meshes] == ["blob", "tet"]
    for mesh in doc.meshes:
        ext = mesh.extras["sgpipe_green06"]
        full, _ = tr_art.read_sh_transfer_rgb(run / "transport", mesh.name)
        shadowed, _ = tr_art.read_sh_transfer(run / "transport", mesh.name)
        x = len(full)
        acc = doc.accessors[ext["transfer_rgb_accessor"]]
        assert (acc.type, acc.componentType, acc.count) == (gl.VEC3, gl.FLOAT, x * 25)
        table = _accessor(doc, blob, ext["transfer_rgb_accessor"])
        t = np.stack([table[v * 25 + k] for v in range(x) for k in range(25)]).reshape(x, 25, 3)
        np.testing.assert_array_equal(t, full)
        assert np.abs(full - shadowed[..., None]).max() > 0.01        # indirect is there
        assert "transfer_rgb[x*25 + k]" in ext["transfer_rgb_decode"]
        prim = mesh.primitives[0]
        sh = np.concatenate([_accessor(doc, blob, getattr(prim.attributes, f"_SH_TRANSFER{j}"))
                             for j in range(7)], 1)
        np.testing.assert_array_equal(sh[:, :25], shadowed)
        assert _accessor(doc, blob, prim.attributes.POSITION).shape == (x, 3)


def test_zero_indirect_adds_nothing(tiny_run, tmp_path):
    """transfer_indirect all zero (what the stage writes without transport.indirect): no table,
    no decode text."""
    _, doc, _ = _export(tiny_run, tmp_path, indirect=False)
    for mesh in doc.meshes:
        ext = mesh.extras["sgpipe_green06"]
        assert "transfer_rgb_accessor" not in ext and "transfer_rgb_decode" not in ext
