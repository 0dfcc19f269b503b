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
