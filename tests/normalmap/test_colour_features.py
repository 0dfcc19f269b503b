"""Han07 eq 22 end to end: the normalmap stage filters the colour textures of the objects that
share a map into the vMF lobes (`normalmap.colour_features`), vmf.npz stores α·f, and the vmf
kernel shades every lobe in its own colour — under lights, the environment and its point set."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import yaml

from sgpipe.render.envdata import EnvData
from sgpipe.render.normalmap_data import NormalMapPyramid
from sgpipe.render.renderer import Light
from tests.normalmap.helpers import tilted_normals, write_image
from tests.normalmap.render_mirror import flat_frame, rbar_of_kappa, renderer, unit

PLANE = ("v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
         "vn 0 1 0\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")


def _precompute(tmp, *, features=True):
    """Three planes on one 16² normal map: a and c of material A (kd 32², ks 16² textures), b of
    material B (another kd texture); `sgpipe precompute` → the normalmap folder."""
    (tmp / "plane.obj").write_text(PLANE)
    write_image(tmp / "nm.png", (tilted_normals(16, seed=4, spread=0.6) + 1) / 2, "uint16")
    rng = np.random.default_rng(1)
    write_image(tmp / "kd_a.png", rng.uniform(0, 1, (32, 32, 3)), "uint16")
    write_image(tmp / "ks_a.png", rng.uniform(0, 1, (16, 16, 3)), "uint16")
    write_image(tmp / "kd_b.png", rng.uniform(0, 1, (16, 16, 3)), "uint16")
    mats = [{"name": n, "model": "blinn_phong", "params": {"exponent": 40, "kd": 0.4,
                                                          "ks": 0.4}} for n in "AB"]
    cfg = {"name": "feat", "seed": 0, "workers": 1,
           "scene": {"objects": [{"name": k, "mesh": "plane.obj", "material": mt,
                                  "normal_map": "nm.png"} for k, mt in
                                 (("a", "A"), ("b", "B"), ("c", "A"))]},
           "fit": {"materials": mats},
           "normalmap": {"lobes": 2, "methods": ["vmf", "baselines"],
                         "colour_features": features},
           "render": {"methods": ["vmf"],
                      "material_textures": [{"material": "A", "kd_map": "kd_a.png",
                                             "ks_map": "ks_a.png"},
                                            {"material": "B", "kd_map": "kd_b.png"}]}}
    (tmp / "c.yaml").write_text(yaml.safe_dump(cfg))
    r = subprocess.run([sys.executable, "-m", "sgpipe", "precompute", str(tmp / "c.yaml"),
                        "--out", str(tmp / "out")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    return tmp / "out" / "normalmap"


def test_stage_filters_each_texture_set_into_its_own_pyramid(tmp_path):
    """Objects sharing the map and their textures share a pyramid; another texture set gets its
    own. Every level's Σ_j α_j f_j is the box mean of the features on the map's grid (the 32²
    kd texture box-averaged to 16², a missing ks texture 1), level 0 the texel's own."""
    from sgpipe.artifacts.normalmap import read_vmf
    from sgpipe.normalmap.features import NAMES
    from sgpipe.render.setup import read_texture
    nm = _precompute(tmp_path)
    maps = json.loads((nm / "index.json").read_text())["maps"]
    assert [m["objects"] for m in maps] == [["a", "c"], ["b"]]
    for m, kd, ks in ((maps[0], "kd_a.png", "ks_a.png"), (maps[1], "kd_b.png", None)):
        f = np.ones((16, 16, len(NAMES)))
        k = read_texture(tmp_path / kd, "kd").astype(np.float64)
        f[..., :3] = k.reshape(16, k.shape[0] // 16, 16, k.shape[1] // 16, 3).mean((1, 3))
        if ks:
            f[..., 3:] = read_texture(tmp_path / ks, "ks")
        v = read_vmf(nm, m["name"])
        assert v.alpha_f is not None and len(v.alpha_f) == len(v.alpha)
        np.testing.assert_allclose(v.alpha_f[0].sum(2), f, atol=1e-6)
        for lev in range(1, len(v.alpha)):
            s = 16 >> lev
            box = f.reshape(s, 16 // s, s, 16 // s, -1).mean((1, 3))
            np.testing.assert_allclose(v.alpha_f[lev].sum(2), box, atol=2e-6)
        assert (nm / m["name"] / "vmf_lobe0_features.png").is_file()


def test_render_refuses_pyramids_made_with_other_colour_textures(tmp_path):
    """The features are the material textures filtered with the normals: `sgpipe render` with
    another kd_map than the pyramids were made with names the normalmap stage and the key (exit
    2); without colour features the textures are the render's own inputs."""
    _precompute(tmp_path)
    fit = subprocess.run([sys.executable, "-m", "sgpipe", "fit", str(tmp_path / "c.yaml"),
                          "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert fit.returncode == 0, fit.stderr[-2000:]
    write_image(tmp_path / "kd_c.png", np.full((16, 16, 3), 0.5), "uint16")
    cmd = [sys.executable, "-m", "sgpipe", "render", str(tmp_path / "c.yaml"), "--out",
           str(tmp_path / "out"), "--set", "render.material_textures.1.kd_map=kd_c.png"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    err = [ln for ln in r.stderr.splitlines() if ln.startswith("sgpipe: error:")]
    assert r.returncode == 2 and len(err) == 1, r.stderr[-2000:]
    assert "normalmap: was made for another config" in err[0]
    assert "render.material_textures.1.kd_map" in err[0], err[0]
    r = subprocess.run(cmd + ["--set", "normalmap.colour_features=false"], capture_output=True,
                       text=True)
    assert "render.material_textures" not in r.stderr, r.stderr[-2000:]


def test_without_colour_features_one_pyramid_and_no_features(tmp_path):
    from sgpipe.artifacts.normalmap import read_vmf
    nm = _precompute(tmp_path, features=False)
    maps = json.loads((nm / "index.json").read_text())["maps"]
    assert [m["objects"] for m in maps] == [["a", "b", "c"]]
    assert read_vmf(nm, maps[0]["name"]).alpha_f is None


def _two_lobe_pyramid(colours):
    """Level 1 (1×1): two vMF lobes (α 0.6 / 0.4, κ 40 / 15, tilted ±30° about y) with feature
    vectors `colours` (2, 6); its mean normal Σ_j α_j r_j (what the lobes hold); level 0 (2×2)
    never read at the test's footprint."""
    mus = unit(np.array([[0.5, 0.0, 0.866], [-0.5, 0.1, 0.86]]))
    al = np.array([0.6, 0.4])
    r = np.array([rbar_of_kappa(40.0), rbar_of_kappa(15.0)])[:, None] * mus
    a1 = al.reshape(1, 1, 2).astype(np.float32)
    ar1 = (al[:, None] * r).reshape(1, 1, 2, 3).astype(np.float32)
    af1 = (al[:, None] * np.asarray(colours)).reshape(1, 1, 2, 6).astype(np.float32)
    a0 = np.zeros((2, 2, 2), np.float32)
    a0[..., 0] = 1.0
    ar0 = np.zeros((2, 2, 2, 3), np.float32)
    ar0[..., 0, :] = [0, 0, 1.0]
    af0 = np.zeros((2, 2, 2, 6), np.float32)
    af0[..., 0, :] = 1.0
    mean = [np.tile([0, 0, 1.0], (2, 2, 1)).astype(np.float32),
            ar1.sum(2).reshape(1, 1, 3)]
    return NormalMapPyramid([a0, a1], [ar0, ar1], mean, alpha_f=[af0, af1])


@pytest.mark.parametrize("model,param", [("blinn_phong", 30.0), ("beckmann", 0.2)])
def test_each_lobe_shades_in_its_own_colour(model, param):
    """Superposition: with lobe colours c₁, c₂ (kd and ks features) the vmf image is c₁ × the
    image of lobe 1 alone in white plus c₂ × lobe 2's — lights, environment (diffuse and
    specular) and the point set alike — and the two alone sum to the white image. Lambert
    under a directional light: E/π kd Σ_j α_j f_j max(0, r_j·i) (eq 22 with eq 5's linear
    cosine per lobe)."""
    rng = np.random.default_rng(2)
    c = rng.uniform(0.2, 1.0, (2, 6))
    n = 12
    th, ph = np.radians(rng.uniform(0, 60, n)), rng.uniform(-np.pi, np.pi, n)
    views = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    duv = np.zeros((n, 4))
    duv[:, 0] = duv[:, 3] = 4.0                        # the 1×1 level
    fr = flat_frame(views, np.full((n, 2), 0.3), duv)
    light = Light("directional", tuple(unit([0.4, -0.2, 1.0])), (1.0, 0.9, 0.8))
    env = EnvData.constant(0.6)

    def shade(cols, mdl=model, prm=param):
        r = renderer(mdl, prm, _two_lobe_pyramid(cols), kd=0.3, ks=0.5, lights=[light],
                     env=env, env_sh=np.zeros((9, 3)), env_specular=True)
        return r.shade("vmf", fr)[:, :3].astype(np.float64)

    one, zero = np.ones(6), np.zeros(6)
    both = shade(c)
    first, second, white = shade([one, zero]), shade([zero, one]), shade([one, one])
    assert first.max() > 1e-3 and second.max() > 1e-3
    np.testing.assert_allclose(first + second, white, rtol=2e-4, atol=1e-6)
    # kd and ks features enter their own terms: a colour per term, so compare channel-wise
    # with the same colour in kd and ks
    cc = np.repeat(c[:, :3], 2, axis=0).reshape(2, 6)
    want = cc[0, :3] * first + cc[1, :3] * second
    np.testing.assert_allclose(shade(cc), want, rtol=2e-4, atol=1e-6)
    assert np.abs(both - white).max() > 1e-3        # the colours do change the image
    # Lambert, the light only (the environment off): the closed form
    r = renderer("lambert", 1.0, _two_lobe_pyramid(c), kd=0.7, lights=[light])
    img = r.shade("vmf", fr)[:, :3].astype(np.float64)
    pyr = _two_lobe_pyramid(c)
    i = np.asarray(light.vector)
    al = pyr.alpha[1][0, 0]
    rr = pyr.alpha_r[1][0, 0] / al[:, None]
    kd = 0.7 * (pyr.alpha_f[1][0, 0][:, :3] / al[:, None])
    want = np.asarray(light.intensity) / np.pi * sum(
        al[j] * kd[j] * max(rr[j] @ i, 0.0) for j in range(2))
    np.testing.assert_allclose(img, np.tile(want, (n, 1)), rtol=1e-4)
