"""`sgpipe compare` through the real CLI: table, --json, --diff PNG, bad inputs exit 2."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from sgpipe.io import read_exr, write_exr


def sgpipe(*args):
    return subprocess.run([sys.executable, "-m", "sgpipe", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


@pytest.fixture
def pair(tmp_path):
    rng = np.random.default_rng(0)
    ref = rng.uniform(0.0, 1.0, (16, 20, 3)).astype(np.float32)
    sign = np.where(np.indices(ref.shape).sum(0) % 2 == 0, 1.0, -1.0).astype(np.float32)
    img = ref + 0.0625 * sign          # exact in float32: MSE = 0.0625²
    a, b = tmp_path / "a.exr", tmp_path / "ref.exr"
    write_exr(a, img)
    write_exr(b, ref)
    return a, b


def test_json_output_and_diff_png(pair, tmp_path):
    a, b = pair
    diff = tmp_path / "d.png"
    res = sgpipe("compare", a, b, "--json", "--diff", diff)
    assert res.returncode == 0, res.stderr
    d = json.loads(res.stdout)
    ia, ib = read_exr(a), read_exr(b)
    mse = float(np.mean((ia.astype(np.float64) - ib) ** 2))
    assert d["mse"] == pytest.approx(mse, rel=1e-9)
    assert d["psnr_db"] == pytest.approx(10 * math.log10(1.0 / mse), abs=1e-9)
    assert d["peak"] == 1.0 and 0 < d["ssim"] < 1 and d["rel_mse"] > 0
    assert d["identical"] is False
    assert diff.is_file() and diff.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    png = read_exr(diff)  # OpenImageIO reads PNG too
    assert png.shape == (16, 20, 3)


def test_table_output_and_identical(pair):
    a, _ = pair
    res = sgpipe("compare", a, a)
    assert res.returncode == 0, res.stderr
    assert "PSNR" in res.stdout and "inf (identical)" in res.stdout and "SSIM" in res.stdout
    res = sgpipe("compare", a, a, "--json")
    d = json.loads(res.stdout)
    assert d["psnr_db"] is None and d["identical"] is True and d["ssim"] == pytest.approx(1)


def test_size_mismatch_is_bad_input(pair, tmp_path):
    a, _ = pair
    small = tmp_path / "small.exr"
    write_exr(small, np.zeros((8, 8, 3), np.float32))
    diff = tmp_path / "d.png"
    res = sgpipe("compare", a, small, "--diff", diff)
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("sgpipe: error:")]
    assert len(lines) == 1 and "differs" in lines[0] and str(a) in lines[0]
    assert "Traceback" not in res.stderr and not diff.exists()


def test_missing_and_nonfinite_inputs(pair, tmp_path):
    a, _ = pair
    res = sgpipe("compare", a, tmp_path / "nope.exr")
    assert res.returncode == 2 and "nope.exr" in res.stderr
    bad = tmp_path / "nan.exr"
    img = np.ones((16, 20, 3), np.float32)
    img[3, 4, 1] = np.nan
    write_exr(bad, img)
    res = sgpipe("compare", bad, a)
    assert res.returncode == 2 and "NaN" in res.stderr


def test_render_stage_hook_writes_diff_and_report(tmp_path):
    """compare_to_reference inside a StageRun: diff PNG published, metrics in the manifest."""
    from sgpipe.stages.base import StageRun
    from sgpipe.stages.compare import compare_to_reference

    ref = np.full((8, 10, 3), 0.5, np.float32)
    img = ref.copy()
    img[2, 3] += 0.25
    with StageRun(None, tmp_path, "render", params={"x": 1}) as run:
        d = compare_to_reference(run, img, ref, "sg")
        same = compare_to_reference(run, ref, ref, "fis")
    man = json.loads((tmp_path / "render" / "manifest.json").read_text())
    rep = man["report"]["compare"]
    assert rep["sg"]["mse"] == pytest.approx(0.25 ** 2 * 3 / ref.size)
    assert rep["sg"]["psnr_db"] == pytest.approx(d["psnr_db"])
    assert rep["fis"]["psnr_db"] is None and rep["fis"]["identical"] is True and same["ssim"] == 1
    assert (tmp_path / "render" / "sg.diff.png").is_file()
    assert "sg.diff.png" in man["outputs"]


# --- display metrics, thresholds, render folders, JUnit ------------------------------------

def test_display_metrics_in_json_and_table(pair):
    a, b = pair
    res = sgpipe("compare", a, b, "--json")
    d = json.loads(res.stdout)
    from sgpipe.io.png import tonemap_srgb
    ca, cb = (tonemap_srgb(read_exr(p)).astype(float) for p in (a, b))
    want = 10 * math.log10(255 ** 2 / np.mean((ca - cb) ** 2))
    assert d["display_psnr_db"] == pytest.approx(want, abs=1e-9)
    assert 0 < d["flip_ldr"] < 1 and 0 < d["flip_hdr"] < 1 and "surface" not in d
    res = sgpipe("compare", a, b)
    lines = res.stdout.splitlines()
    assert [ln.split()[0] for ln in lines[3:6]] == ["display", "LDR-FLIP", "HDR-FLIP"]
    assert any(ln.startswith("linear PSNR") for ln in lines)


def test_thresholds_exit_1_with_one_line_per_failure(pair, tmp_path):
    a, b = pair
    d = json.loads(sgpipe("compare", a, b, "--json").stdout)
    ok = sgpipe("compare", a, b, "--min-psnr", d["display_psnr_db"] - 0.01,
                "--max-flip", d["flip_ldr"] + 1e-4, "--max-relmse", 1)
    assert ok.returncode == 0, ok.stderr
    junit = tmp_path / "j.xml"
    bad = sgpipe("compare", a, b, "--min-psnr", d["display_psnr_db"] + 0.01,
                 "--max-flip", d["flip_ldr"] - 1e-4, "--max-relmse", 1, "--junit", junit)
    assert bad.returncode == 1
    fails = [ln for ln in bad.stderr.splitlines() if "FAIL" in ln]
    assert len(fails) == 2 and "--min-psnr" in fails[0] and "--max-flip" in fails[1]
    assert "PSNR" in bad.stdout                         # the table is still printed
    import xml.etree.ElementTree as ET
    root = ET.parse(junit).getroot()
    cases = root.findall("./testsuite/testcase")
    failed = [c.get("name") for c in cases if c.find("failure") is not None]
    assert len(cases) == 4 and len(failed) == 2 and root.get("failures") == "2"
    assert failed[0].startswith("display PSNR >=") and failed[1].startswith("LDR-FLIP <=")
    res = sgpipe("compare", a, b, "--min-surface-psnr", 10)   # no G-buffer: surfaces fail
    assert res.returncode == 1 and "no G-buffer" in res.stderr


def _render_folder(path, sg_noise, seed=0):
    """A render folder as the render stage writes it (manifest params, EXRs, gbuffer)."""
    from sgpipe.io import write_npz
    path.mkdir(parents=True)
    rng = np.random.default_rng(seed)
    ref = rng.uniform(0.05, 0.9, (24, 32, 3)).astype(np.float32)
    write_exr(path / "reference.exr", ref)
    noise = np.random.default_rng(1).normal(0, 1, ref.shape)
    write_exr(path / "sg.exr", np.clip(ref + sg_noise * noise, 0, None).astype(np.float32))
    write_exr(path / "fis.exr", ref)
    ids = np.full((24, 32), -1, np.int32)
    ids[4:20, 4:28] = 0
    write_npz(path / "gbuffer.npz", {"object_id": ids})
    (path / "manifest.json").write_text(json.dumps({"params": {"render": {
        "methods": ["sg", "fis", "reference"], "compare_to": "reference",
        "preview_exposure": 0.0}}}))
    return path


def test_render_folders_method_by_method(tmp_path):
    base = _render_folder(tmp_path / "base" / "render", 0.02)
    same = _render_folder(tmp_path / "same" / "render", 0.02, seed=4)
    worse = _render_folder(tmp_path / "worse" / "render", 0.05)
    res = sgpipe("compare", base, "--json")
    assert res.returncode == 0, res.stderr
    d = json.loads(res.stdout)
    assert set(d["methods"]) == {"sg", "fis"} and d["truth"] == "reference"
    sg = d["methods"]["sg"]
    assert sg["surface"]["pixels"] == 14 * 22 and d["methods"]["fis"]["identical"] is True
    assert sgpipe("compare", same, base).returncode == 0
    junit = tmp_path / "reg.xml"
    res = sgpipe("compare", worse, base, "--junit", junit)
    assert res.returncode == 1
    fails = [ln for ln in res.stderr.splitlines() if "FAIL" in ln]
    assert len(fails) == 2 and all("FAIL sg:" in ln for ln in fails), res.stderr
    assert "candidate" in res.stdout and "baseline" in res.stdout
    import xml.etree.ElementTree as ET
    cases = ET.parse(junit).getroot().findall("./testsuite/testcase")
    failed = {(c.get("classname"), c.get("name").split()[0]) for c in cases
              if c.find("failure") is not None}
    assert failed == {("sgpipe.compare.sg", "display"), ("sgpipe.compare.sg", "LDR-FLIP")}
    # a looser tolerance lets the same pair pass
    assert sgpipe("compare", worse, base, "--max-psnr-drop", 50,
                  "--max-flip-rise", 1).returncode == 0
    res = sgpipe("compare", base, "--truth", "nope")
    assert res.returncode == 2 and "nope.exr" in res.stderr


def test_render_stage_reports_display_metrics_and_surfaces(tmp_path):
    """The real render stage (tiny scene): report.compare gains display PSNR, FLIP, surfaces;
    the log line leads with display PSNR; `compare` on the folder gives the same numbers."""
    from tiny_scene import tiny_config  # tests/ is on sys.path
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(tiny_config())
    out = tmp_path / "out"
    res = sgpipe("run", cfg, "--out", out)
    assert res.returncode == 0, res.stderr
    line = [ln for ln in res.stderr.splitlines() if "sg vs reference" in ln]
    assert line and line[0].split("sg vs reference: ")[1].startswith("display PSNR")
    rep = json.loads((out / "render" / "manifest.json").read_text())["report"]["compare"]["sg"]
    assert 0 < rep["flip_ldr"] < 1 and rep["surface"]["pixels"] > 0
    d = json.loads(sgpipe("compare", out / "render", "--json").stdout)["methods"]["sg"]
    for k in ("display_psnr_db", "flip_ldr", "flip_hdr", "rel_mse", "psnr_db"):
        assert d[k] == pytest.approx(rep[k], rel=1e-6), k
        assert d["surface"][k] == pytest.approx(rep["surface"][k], rel=1e-6), k
