"""`sgpipe precompute` env part: artifacts of docs/ARTIFACTS.md, skip/rerun, bad input."""
import json
import subprocess
import sys

import numpy as np
import pytest

from sgpipe.artifacts import envmap as art
from sgpipe.config import load_config
from sgpipe.core.maps import latlong_texel_dirs
from sgpipe.envmap import store
from sgpipe.core.maps import image_to_faces
from sgpipe.io import read_exr, write_exr
from sgpipe.stages import envmap as stage

from .envmap_helpers import brute_gamma, probe_directions, sky


@pytest.fixture(scope="module")
def env_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("env")
    d = latlong_texel_dirs(64, 128)
    img = sky(d)
    img[20, 40] += 3e4                                 # tiny sun
    write_exr(tmp / "env.exr", img.astype(np.float32))
    cfg_path = tmp / "cfg.yaml"
    cfg_path.write_text("name: t\nenvmap:\n  environment: env.exr\n  cube_resolution: 16\n"
                        "  sg_lobes: 3\n  irradiance_height: 8\n")
    cfg = load_config(cfg_path, [])
    out = tmp / "out"
    stage.run(cfg, out)
    return cfg, out, cfg_path


def test_artifacts_follow_the_contract(env_run):
    _, out, _ = env_run
    f = out / "envmap"
    idx = np.load(f / "pyramid.npz")
    lam, res = idx["lambdas"], idx["face_res"]
    assert lam[0] == pytest.approx((16 / 4) ** 2) and np.all(np.diff(lam) < 0)
    for l, n in enumerate(res):
        img, meta = read_exr(f / f"pyramid/level_{l:02d}.exr", with_metadata=True)
        assert img.shape == (6 * (n + 2), n + 2, 3) and meta["border"] == 1
        assert meta["lambda"] == pytest.approx(lam[l])
        for kind in ("coef", "slope"):
            img, meta = read_exr(f / f"pyramid/{kind}_{l:02d}.exr", with_metadata=True)
            assert img.shape == (6 * (n + 4), n + 4, 3) and meta["border"] == 2
    assert idx["offsets"][-1] == sum(6 * (n + 2) ** 2 for n in res)
    assert idx["coef_offsets"][-1] == sum(6 * (n + 4) ** 2 for n in res)
    for name in ("mip.npz", "light_sg.npz", "light_sh.npz", "irradiance.exr",
                 "preview_pyramid.png", "preview_light_fit.png", "preview_irradiance.png",
                 "mip/cube_00.exr", "mip/cube_04.exr", "mip/dp_00.exr", "manifest.json"):
        assert (f / name).is_file(), name
    fits = store.load_light_fits(f)
    assert art.read_irradiance(f).shape == (8, 16, 3)
    assert fits["sg"].axes.shape == (3, 3) and fits["sh"]["coeffs"].shape == (25, 3)
    man = json.loads((f / "manifest.json").read_text())
    assert max(man["report"]["sg_light_irradiance_rel_err"]) < 0.05


def test_loaded_pyramid_matches_brute_force_over_the_stage_cubemap(env_run):
    _, out, _ = env_run
    pyr = store.load_pyramid(out / "envmap")
    cube = image_to_faces(read_exr(out / "envmap/mip/cube_00.exr"))[:, 1:-1, 1:-1]
    d = probe_directions(300)
    for lam in (0.7, 5.0, 16.0):
        ref = brute_gamma(cube, d, lam)
        np.testing.assert_allclose(pyr.lookup(d, lam), ref, rtol=0.01)
    # the cheap path (bilinear samples, linear in ln λ) on a level is exact at texel centres
    n = int(pyr.face_res[2])
    from sgpipe.core.maps import cubemap_texel_dirs
    c = cubemap_texel_dirs(n).reshape(-1, 3)
    lam2 = float(pyr.lambdas[2])
    np.testing.assert_allclose(pyr.lookup_simple(c, lam2), brute_gamma(cube, c, lam2), rtol=0.01)
    ch = store.load_mip_chain(out / "envmap", "dp")
    assert ch.kind == "dp" and ch.b == pytest.approx(1.2)


def test_rerun_is_skipped_and_forced_rerun_is_byte_identical(env_run):
    cfg, out, _ = env_run
    before = json.loads((out / "envmap/manifest.json").read_text())["outputs"]
    assert stage.run(cfg, out).skipped
    stage.run(cfg, out, force=True)
    after = json.loads((out / "envmap/manifest.json").read_text())["outputs"]
    assert before == after


def test_cli_bad_environment_exits_2(tmp_path):
    bad = np.ones((8, 16, 3), np.float32)
    bad[1, 1, 0] = np.nan
    write_exr(tmp_path / "bad.exr", bad)
    (tmp_path / "c.yaml").write_text("envmap:\n  environment: bad.exr\n  cube_resolution: 8\n")
    r = subprocess.run([sys.executable, "-m", "sgpipe", "precompute", str(tmp_path / "c.yaml"),
                        "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode == 2
    assert "bad.exr" in r.stderr and "envmap.environment" in r.stderr and "NaN" in r.stderr
    assert not (tmp_path / "o" / "envmap").exists()
