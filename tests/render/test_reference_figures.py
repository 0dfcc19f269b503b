"""`make figures` plumbing without running the stages: config building through the schema,
contact-sheet layout (missing methods shown as crossed tiles), RESULTS.md tables."""

import math

import numpy as np

from sgpipe.experiments.figures import DATA, WARD_ALPHAS, build_config, materials
from sgpipe.experiments.sheets import contact_sheet, write_results_md
from sgpipe.io import read_exr


def test_materials_and_config():
    mats = materials()
    names = [m["name"] for m in mats]
    assert [f"ward_a{a:g}" for a in WARD_ALPHAS] == names[:5]
    aniso = mats[names.index("ward_aniso")]["params"]
    assert (aniso["alpha_u"], aniso["alpha_v"]) == (0.01, 0.2)
    assert sum(n.startswith("beckmann") for n in names) == 5
    assert sum(n.startswith("ggx") for n in names) == 5
    cfg = build_config(DATA / "studio.exr", mats, "ggx_a0.1", ["reference", "sg"], size=24,
                       spp=8, seed=3, workers=1)
    assert cfg.scene.objects[0].material == "ggx_a0.1"
    assert cfg.render.camera.width == 24 and cfg.render.spp == 8 and cfg.seed == 3
    assert cfg.render.methods == ["reference", "sg"] and cfg.render.background is False
    from sgpipe.brdf import make_brdf
    for m in cfg.fit.materials:   # every material is a valid registry BRDF
        make_brdf(m.model, m.params)


def test_contact_sheet_and_results(tmp_path):
    rng = np.random.default_rng(0)
    ref = rng.uniform(0, 1, (6, 8, 3)).astype(np.float32)
    rows = [("a", {"reference": {"image": ref, "ms": 12.0, "rms_stderr": 0.01},
                   "sg": {"image": ref + 0.1, "ms": 0.5, "psnr_db": 20.0, "ssim": 0.9},
                   "fis": {"error": "BadInput: nope"}, "gmm": {"error": "BadInput: nope"}})]
    p = contact_sheet(tmp_path / "s.png", rows, ("fis", "sg", "gmm"))
    sheet = read_exr(p)
    assert sheet.shape == (6, 7 * 8 + 6 * 2, 3)
    sg_diff = sheet[:, 4 * 10:4 * 10 + 8]     # column 4: sg difference, uniformly brighter
    assert (sg_diff[..., 0] > sg_diff[..., 2]).all()
    mats = [{"name": "a", "alpha": "0.1"}]
    md = write_results_md(tmp_path / "R.md", {"studio": {"results": dict(rows),
                                                         "upstream": {"fit": None}}},
                          mats, ("fis", "sg", "gmm"), [("studio", "ward", "figures/s.png")],
                          size=8, spp=4, seed=0, seconds=1.0, command="x").read_text()
    assert "| a | 0.1 | missing | 20.00 | missing |" in md
    assert f"{10 * math.log10(1 / 0.01 ** 2):.1f}" in md
    assert "`fis` (studio): BadInput: nope" in md and "figures/s.png" in md
