"""The normalmap stage's vMF and roughness MIP chains as 2-D KTX2 / DDS textures."""

import shutil
import struct

import numpy as np

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import normalmap as nm_art
from sgpipe.export import dds, ktx2
from sgpipe.export.bundle import write_export


def _normal_map_artifacts(root, name="bumps", side=8, levels=4, lobes=2):
    rng = np.random.default_rng(11)
    alpha = [rng.uniform(0, 1, (side >> l, side >> l, lobes)) for l in range(levels)]
    alpha_r = [rng.uniform(-1, 1, (side >> l, side >> l, lobes, 3)) for l in range(levels)]
    mean = [rng.normal(size=(side >> l, side >> l, 3)) for l in range(levels)]
    scal = [rng.uniform(0, 1, (side >> l, side >> l)) for l in range(levels)]
    sink = FolderSink(root / "normalmap")
    nm_art.write_vmf(sink, name, alpha, alpha_r, kappa_max=1e4, aligned=True)
    nm_art.write_baselines(sink, name, mean=mean, toksvig=scal, kappa=scal, roughness=scal,
                           toksvig_exponent=32.0, engine_alpha=0.1)
    return alpha, alpha_r, scal


def test_vmf_and_roughness_chains(tiny_run, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(tiny_run["dir"], run)
    alpha, alpha_r, rough = _normal_map_artifacts(run)
    out = write_export(run, tmp_path / "export")
    folder = out / "normalmap" / "bumps"
    assert sorted(p.name for p in folder.iterdir()) == [
        "roughness.dds", "roughness.ktx2", "vmf_lobe0.dds", "vmf_lobe0.ktx2", "vmf_lobe1.dds",
        "vmf_lobe1.ktx2"]
    for j in range(2):
        buf = (folder / f"vmf_lobe{j}.ktx2").read_bytes()
        # 2-D: faceCount 1, pixelDepth 0, layerCount 0; 4 levels of 8² … 1²
        assert struct.unpack_from("<9I", buf, 12) == (97, 2, 8, 8, 0, 0, 1, 4, 0)
        k = ktx2.read_ktx2(buf)
        d = dds.read_dds((folder / f"vmf_lobe{j}.dds").read_bytes())
        assert d["caps"][1] == 0 and d["dx10"][2] == 0             # not a cube
        for m in range(4):
            want = np.concatenate([alpha_r[m][..., j, :], alpha[m][..., j:j + 1]], -1)
            want = want.astype(np.float32).astype(np.float16)
            np.testing.assert_array_equal(k["levels"][m][0], want)
            np.testing.assert_array_equal(d["levels"][m][0], want)
    k = ktx2.read_ktx2((folder / "roughness.ktx2").read_bytes())
    assert (k["header"]["vk_format"], k["header"]["type_size"]) == (76, 2)     # R16_SFLOAT
    assert (k["dfd"]["total_size"], k["dfd"]["bytes_plane"][0]) == (44, 2)
    assert [(s["bit_offset"], s["bit_length"], s["channel"], s["qualifiers"])
            for s in k["dfd"]["samples"]] == [(0, 16, 0, 0xC0)]
    assert all(e["offset"] % 4 == 0 for e in k["level_index"])
    d = dds.read_dds((folder / "roughness.dds").read_bytes())
    assert d["dx10"][0] == 54 and d["end"] == len((folder / "roughness.dds").read_bytes())
    for m in range(4):
        want = rough[m].astype(np.float32).astype(np.float16)[..., None]
        np.testing.assert_array_equal(k["levels"][m][0], want)
        np.testing.assert_array_equal(d["levels"][m][0], want)
