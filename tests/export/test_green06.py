"""Green06's per-vertex transport in the glTF: decoded with only the file and the documented
layout, it equals the transport stage's own decoding of its compact arrays."""

import shutil

import numpy as np
import pygltflib as gl

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import transport as tr_art
from sgpipe.export.bundle import write_export
from sgpipe.transport import compact
from sgpipe.transport.views import N_VIEWS, view_set

from .test_command import _accessor


def _transport_object(root, name, positions, normals, faces, k=2, seed=0):
    rng = np.random.default_rng(seed)
    x = len(positions)
    mu = rng.normal(size=(x, N_VIEWS, k, 3))
    mu /= np.linalg.norm(mu, axis=-1, keepdims=True)
    sigma = rng.uniform(0.05, 0.8, (x, N_VIEWS, k))
    w = rng.uniform(0, 3, (x, N_VIEWS, k, 3)) * (rng.uniform(size=(x, N_VIEWS, 1, 1)) < 0.4)
    packed = compact.encode(mu, sigma, w, 0.02, 1.0)
    sh = rng.normal(size=(x, 25))
    tr_art.write_object(FolderSink(root / "transport"), name, packed=packed,
                        cube_resolution=8, gaussians=k, sh=sh, diffuse_rgb=[0.5, 0.4, 0.3],
                        positions=positions, normals=normals, faces=faces)
    return packed, sh


def _oct_decode(e):
    q = e.astype(float) / 65535 * 2 - 1
    x, y = q[..., 0], q[..., 1]
    z = 1 - np.abs(x) - np.abs(y)
    t = np.maximum(-z, 0)
    v = np.stack([x - np.where(x >= 0, t, -t), y - np.where(y >= 0, t, -t), z], -1)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _decode_from_gltf(doc, blob, prim, ext):
    a = prim.attributes
    get = lambda name: _accessor(doc, blob, getattr(a, name))          # noqa: E731
    table = lambda name: _accessor(doc, blob, ext[f"{name}_accessor"])  # noqa: E731
    stored = np.concatenate([get(f"_G06_STORED{j}") for j in range(3)], 1).astype(np.uint8)
    weighted = np.concatenate([get(f"_G06_WEIGHTED{j}") for j in range(3)], 1).astype(np.uint8)
    row0, wrow0, scale = get("_G06_ROW")[:, 0], get("_G06_WROW")[:, 0], get("_G06_SCALE")[:, 0]
    k = ext["gaussians"]
    lo, hi = ext["sigma_range"]
    dirs, codes, weights = table("dirs"), table("sigma_code")[:, 0], table("weights")
    x = len(stored)
    mu, sigma, w = np.zeros((x, 92, k, 3)), np.zeros((x, 92, k)), np.zeros((x, 92, k, 3))
    for v in range(x):
        r, rw = int(row0[v]), int(wrow0[v])
        for view in range(92):
            if stored[v, view // 8] >> (view % 8) & 1:
                mu[v, view] = _oct_decode(dirs[r * k:(r + 1) * k])
                sigma[v, view] = np.exp(np.log(lo) + codes[r * k:(r + 1) * k] / 255 *
                                        (np.log(hi) - np.log(lo)))
                r += 1
            if weighted[v, view // 8] >> (view % 8) & 1:
                w[v, view] = weights[rw * k:(rw + 1) * k] * scale[v]
                rw += 1
    return mu, sigma, w


def test_green06_attributes_and_tables(tiny_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(tiny_run["dir"], run)
    obj = tiny_run["object"]
    same, sh_same = _transport_object(run, "blob", obj["positions"], obj["normals"],
                                      obj["faces"])
    pos2 = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    other, sh_other = _transport_object(run, "tet", pos2 + 2.0, pos2 - 0.25, np.array(
        [[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]), seed=1)
    out = write_export(run, tmp_path / "export")
    doc = gl.GLTF2().load(str(out / "scene.gltf"))
    blob = (out / "scene.bin").read_bytes()
    assert [m.name for m in doc.meshes] == ["blob", "tet"]     # blob's vertices are shared
    assert [n.name for n in doc.nodes] == ["blob", "tet (transport)"]
    for mesh, packed, sh in ((doc.meshes[0], same, sh_same), (doc.meshes[1], other, sh_other)):
        prim = mesh.primitives[0]
        ext = mesh.extras["sgpipe_green06"]
        assert ext["views"] == 92 and ext["gaussians"] == 2
        np.testing.assert_allclose(_accessor(doc, blob, ext["views_accessor"]), view_set()[0],
                                   rtol=1e-7, atol=1e-7)
        t = np.concatenate([_accessor(doc, blob, getattr(prim.attributes, f"_SH_TRANSFER{j}"))
                            for j in range(7)], 1)
        np.testing.assert_allclose(t[:, :25], sh, rtol=1e-6)
        assert np.all(t[:, 25:] == 0)
        mu, sigma, w = _decode_from_gltf(doc, blob, prim, ext)
        mu_ref, sigma_ref, w_ref, stored = compact.decode(packed)
        np.testing.assert_allclose(mu[stored], mu_ref[stored], atol=1e-12)
        np.testing.assert_allclose(sigma[stored], sigma_ref[stored], rtol=1e-6)
        np.testing.assert_allclose(w, w_ref, rtol=1e-6)
    assert doc.meshes[0].extras["sgpipe_ssdf"]["terms"] == 6     # beside the SSDF data
