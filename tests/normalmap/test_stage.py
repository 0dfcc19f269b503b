"""The normalmap stage: artifacts per normal map (contract readers, the library's numbers),
skip and byte-identical reruns, the CLI's one-line bad inputs with nothing written."""

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from sgpipe.artifacts import normalmap as art
from sgpipe.config import load_config
from sgpipe.errors import BadInput
from sgpipe.io import read_exr
from sgpipe.normalmap.read import read_normal_map
from sgpipe.normalmap.sh import ndf_sh_pyramid
from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid
from sgpipe.stages import normalmap as stage

from .helpers import write_image

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import sample_normalmaps  # noqa: E402

SAMPLES = Path(__file__).resolve().parents[2] / "data_samples"
CONFIG = """
name: nm
scene:
  objects:
    - {{name: plane, mesh: {floor}, material: m, normal_map: grooves.png}}
    - {{name: ball, sphere_radius: 0.5, material: m, normal_map: grooves.png}}
normalmap: {{sh_order: 2, lobes: 3{extra}}}
"""
#: The texel-centre pyramids, which the library calls below rebuild (the default,
#: bilinear_samples: 2, is tests/normalmap/test_bilinear.py's).
TEXEL_CENTRES = ", bilinear_samples: 1"


def make(tmp_path, extra="", floor=SAMPLES / "floor.obj", lobes=3):
    n = sample_normalmaps.grooves_normals(256)[:32, :32]
    write_image(tmp_path / "grooves.png", n * 0.5 + 0.5, "uint16")
    p = tmp_path / "c.yaml"
    p.write_text(textwrap.dedent(CONFIG.format(floor=floor, extra=extra)).replace(
        "lobes: 3", f"lobes: {lobes}"))
    return load_config(p)


@pytest.fixture(scope="module")
def staged(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("nm")
    cfg = make(tmp, extra=TEXEL_CENTRES)
    stage.run(cfg, tmp / "out")
    return tmp, cfg, tmp / "out" / "normalmap"


def test_artifacts_hold_the_librarys_pyramids(staged):
    tmp, cfg, d = staged
    idx = json.loads((d / art.INDEX).read_text())
    assert idx["maps"] == [{"name": "grooves", "objects": ["plane", "ball"],
                            "file": "grooves.png"}]
    normals = read_normal_map(tmp / "grooves.png")
    vmf = art.read_vmf(d, "grooves")
    want = fit_vmf_pyramid(normals, VMFSettings(lobes=3))
    assert len(vmf.alpha) == 6 and vmf.alpha[0].shape == (32, 32, 3) and vmf.aligned
    for a, b in zip(vmf.alpha + vmf.alpha_r, want.alpha + want.alpha_r):
        np.testing.assert_array_equal(a, b)
    gamma, lmax = art.read_sh(d, "grooves")
    assert lmax == 2
    for a, b in zip(gamma, ndf_sh_pyramid(normals, 2)):
        np.testing.assert_array_equal(a, b.astype(np.float32))
    base = art.read_baselines(d, "grooves")
    assert base["mean"][5].shape == (1, 1, 3) and base["toksvig_exponent"] == 32.0
    # the EXR atlases hold the same levels (lobe 1, level 2; SH level 3; normals level 1)
    lob = art.unpack_atlas(read_exr(d / "grooves" / art.vmf_atlas_name(1)), 6)
    np.testing.assert_array_equal(lob[2][..., 0], vmf.alpha[2][..., 1])
    np.testing.assert_array_equal(lob[2][..., 1:], vmf.alpha_r[2][..., 1, :])
    shx = art.unpack_atlas(read_exr(d / "grooves/sh_ndf.exr"), 6)
    np.testing.assert_array_equal(shx[3], gamma[3])
    for f in ("vmf_lobe0.png", "sh_ndf.png", "normals_mip.png", "toksvig.png",
              "engine_roughness.png", art.PREVIEW_LEVELS):
        assert (d / "grooves" / f).is_file(), f


def test_quality_report_orders_the_methods(staged):
    """Texel-level Blinn–Phong (s = 32) error against the covered normals' mean shading. 32²
    grooves crop, 3 lobes, measured levels 0–5: vMF 0.004 0.004 0.006 0.018 0.044 0.023,
    Toksvig 0 0.11 0.26 0.65 0.66 0.99, normalised MIP 0 0.62 0.81 0.25 0.51 0.61, SH (l ≤ 2,
    too low for s = 32) 0.52–0.63 throughout."""
    _, _, d = staged
    q = json.loads((d / "grooves" / art.QUALITY).read_text())["rel_rms_by_level"]
    assert q["toksvig"][0] == q["normalized"][0] == 0.0     # one normal per texel: exact
    assert q["vmf"][0] < 5e-3                               # κ_max = 1e4: s′ = 31.9, not 32
    for lev in range(1, 6):
        assert q["vmf"][lev] < 0.05, (lev, q)
        assert q["vmf"][lev] < 0.2 * min(q["toksvig"][lev], q["normalized"][lev]), (lev, q)
    man = json.loads((d / "manifest.json").read_text())
    assert man["report"]["grooves"]["rel_rms_by_level"] == q


def test_rerun_skips_and_fresh_run_is_byte_identical(staged, tmp_path):
    tmp, cfg, d = staged
    assert stage.run(cfg, tmp / "out").skipped
    stage.run(make(tmp_path, extra=TEXEL_CENTRES), tmp_path / "o2")
    m1 = json.loads((d / "manifest.json").read_text())["outputs"]
    m2 = json.loads((tmp_path / "o2/normalmap/manifest.json").read_text())["outputs"]
    assert m1 == m2


def test_no_uvs_and_bad_map_are_one_line_nothing_written(tmp_path):
    obj = tmp_path / "nouv.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n")
    cfg = make(tmp_path, floor=obj)
    with pytest.raises(BadInput, match="no texture coordinates") as e:
        stage.run(cfg, tmp_path / "out")
    assert "scene.objects.0.normal_map" in e.value.one_line()
    assert not (tmp_path / "out").exists()
    write_image(tmp_path / "grooves.png", np.full((16, 24, 3), 0.7), "uint8")
    (tmp_path / "c.yaml").write_text((tmp_path / "c.yaml").read_text().replace(
        str(obj), str(SAMPLES / "floor.obj")))
    r = subprocess.run([sys.executable, "-m", "sgpipe", "precompute", str(tmp_path / "c.yaml"),
                        "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    last = r.stderr.strip().splitlines()[-1]
    assert "grooves.png" in last and "power-of-two" in last and "normal_map" in last
    assert not (tmp_path / "out" / "normalmap").exists()


def test_config_bounds(tmp_path):
    with pytest.raises(BadInput, match="<= 8") as e:
        make(tmp_path, lobes=9)
    assert "normalmap.lobes" in e.value.one_line()
    with pytest.raises(BadInput, match="duplicate"):
        make(tmp_path, extra=", methods: [vmf, vmf]")
