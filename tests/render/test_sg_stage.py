"""The render stage end to end on a small shadowed scene (sphere on a floor, sky with a bright
lobe, a point light): envmap/ written in its documented layout by sg_testlib, fit/ and
visibility/ by the real stages; sg, gmm, fis vs the Monte Carlo reference: PSNR floors."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from sg_testlib import latlong_dirs_and_weights, write_env_artifacts
from sgpipe.config import load_config
from sgpipe.io import read_exr, write_exr

pytestmark = [pytest.mark.opencl, pytest.mark.slow]

# PSNR floors (dB, linear RGB, peak = metrics default) of this scene.
FLOORS = {"sg": 26.0, "gmm": 26.0, "fis": 26.0}   # measured 27.3–27.4 dB at 256 spp
# Display PSNR (8-bit previews) whole frame / surface pixels and LDR-ꟻLIP ceilings; measured
# 29.75–29.81 / 28.46–28.53 dB and 0.093 for every method, 3×3 supersampled against the
# box-filtered reference (the 256-spp reference's noise dominates).
DISPLAY_FLOORS = {m: (28.5, 27.2, 0.10) for m in FLOORS}


def _plane_obj(path: Path, n=8, half=2.0):
    xs = np.linspace(-half, half, n + 1)
    lines = []
    for z in xs:
        for x in xs:
            lines.append(f"v {x:.6f} 0 {z:.6f}\nvt {(x + half) / (2 * half):.6f} "
                         f"{1 - (z + half) / (2 * half):.6f}\nvn 0 1 0")
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j + 1
            b, c, d = a + 1, a + n + 1, a + n + 2
            lines.append(f"f {a}/{a}/{a} {c}/{c}/{c} {b}/{b}/{b}")
            lines.append(f"f {b}/{b}/{b} {c}/{c}/{c} {d}/{d}/{d}")
    path.write_text("\n".join(lines) + "\n")


def _sky(h=32, w=64):
    d, _ = latlong_dirs_and_weights(h, w)
    sun = np.array([0.5, 0.75, 0.43])
    sun /= np.linalg.norm(sun)
    base = 0.3 + 0.5 * np.clip(d[..., 1:2], 0, 1) * np.array([0.6, 0.8, 1.0])
    base = np.where(d[..., 1:2] < 0, 0.15, base)
    blob = 12.0 * np.exp(30.0 * (d @ sun - 1.0))[..., None] * np.array([1.0, 0.9, 0.75])
    return (base + blob).astype(np.float32)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sgstage")
    out = tmp / "out"
    _plane_obj(tmp / "plane.obj")
    write_exr(tmp / "sky.exr", _sky())
    write_env_artifacts(out / "envmap", _sky(), N=16)
    cfg = {
        "name": "sgstage", "seed": 0, "workers": 2,
        "scene": {"objects": [
            {"name": "floor", "mesh": "plane.obj", "material": "floor"},
            {"name": "ball", "sphere_radius": 0.5, "translate": [0, 0.5, 0],
             "material": "ball"}]},
        "fit": {"materials": [{"name": "floor", "model": "lambert", "params": {"kd": 0.6}},
                              {"name": "ball", "model": "ggx",
                               "params": {"alpha": 0.25, "kd": 0.25, "ks": 0.6}}],
                "view_gmm": {"lobes": 4, "samples": 1024, "theta_count": 8,
                             "report_lobes": 0, "holdout": False},
                "ndf_sg": {"report_lobes": 0}},
        "envmap": {"environment": "sky.exr"},
        "visibility": {"trace_resolution": 32, "resolution": 16, "pca_terms": 8,
                       "sphere_subdivisions": 2, "report_vertices": 0, "preview_vertices": 0},
        "render": {"camera": {"eye": [0, 1.6, 3.2], "target": [0, 0.35, 0], "fov_deg": 40,
                              "width": 40, "height": 32},
                   "methods": ["sg", "gmm", "fis", "reference"], "spp": 256,
                   "supersample": 3,       # box-filtered like the reference (its default)
                   "fis_samples": 40,
                   "compare_to": "reference", "timing_repeats": 1,
                   "lights": [{"type": "point", "position": [1.5, 2.5, 1.0],
                               "intensity": [3, 3, 3], "radius": 0.02}]},
    }
    (tmp / "c.yaml").write_text(yaml.safe_dump(cfg))
    conf = load_config(tmp / "c.yaml")
    from sgpipe.stages import fit, render, visibility
    fit.run(conf, out)
    visibility.run(conf, out)
    render.run(conf, out)
    return out, conf


def test_stage_writes_images_gbuffer_and_timings(rendered):
    out, _ = rendered
    rd = out / "render"
    for m in ("sg", "gmm", "fis", "reference"):
        img = read_exr(rd / f"{m}.exr")
        assert img.shape == (32, 40, 3) and np.isfinite(img).all()
        assert (rd / f"{m}.png").is_file()
    man = json.loads((rd / "manifest.json").read_text())
    tim = json.loads((rd / "timings.json").read_text())
    assert tim["sg_s"] > 0 and tim["fis_s"] > 0 and "gbuffer_s" in tim
    assert man["report"]["shaded_pixels"] > 500
    g = np.load(rd / "gbuffer.npz")
    assert g["hit"].shape == (32, 40) and set(np.unique(g["object_id"])) == {-1, 0, 1}


def test_sg_and_fis_psnr_floors_against_reference(rendered):
    out, _ = rendered
    man = json.loads((out / "render" / "manifest.json").read_text())
    cmp = man["report"]["compare"]
    for m, floor in FLOORS.items():
        assert cmp[m]["psnr_db"] >= floor, (m, cmp[m]["psnr_db"])
    for m, (whole, surface, flip) in DISPLAY_FLOORS.items():
        d = cmp[m]
        assert d["display_psnr_db"] >= whole, (m, d["display_psnr_db"])
        assert d["surface"]["display_psnr_db"] >= surface, (m, d["surface"]["display_psnr_db"])
        assert d["flip_ldr"] <= flip, (m, d["flip_ldr"])
    # shadows are there: the floor under the ball is darker than the open floor in `sg`
    sg = read_exr(out / "render" / "sg.exr")
    ref = read_exr(out / "render" / "reference.exr")
    g = np.load(out / "render" / "gbuffer.npz")
    floor_px = (g["object_id"] == 0)
    lum = lambda im: im @ np.array([0.2126, 0.7152, 0.0722])
    dark_ref = lum(ref)[floor_px] < np.percentile(lum(ref)[floor_px], 10)
    assert lum(sg)[floor_px][dark_ref].mean() < 0.6 * lum(sg)[floor_px].mean()


def test_rerun_is_skipped_and_bytes_identical(rendered):
    out, conf = rendered
    from sgpipe.stages import render
    before = (out / "render" / "sg.exr").read_bytes()
    run = render.run(conf, out)
    assert run.skipped
    assert (out / "render" / "sg.exr").read_bytes() == before


def test_supersampled_sg_converges_to_the_filtered_reference_at_silhouettes(rendered):
    """sg shaded at 1×1, 2×2 and 3×3 sub-pixel G-buffers (render.supersample) against the
    box-filtered 256-spp reference: on silhouette pixels (3×3 neighbourhood with more than one
    object or the background) the RMS error drops with N (measured 0.0463 → 0.0290 → 0.0242 in
    a gamma-2.2 display domain), while surface pixels stay where the reference's noise holds
    them (0.0380 → 0.0374 → 0.0374)."""
    from sgpipe.metrics import surface_mask
    from sgpipe.render.methods import METHODS
    from sgpipe.render.setup import build_scene
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import Tracer
    from sgpipe.stages.render import supersampled_frames
    out, conf = rendered
    ref = read_exr(out / "render" / "reference.exr")
    g = np.load(out / "render" / "gbuffer.npz")
    surf = surface_mask(g["object_id"])
    sil = ~surf
    assert sil.sum() > 80
    bundle = build_scene(conf, out, [METHODS["sg"]])
    cam = Camera.from_spec(conf.render.camera)
    tracer = Tracer(bundle.objects)
    disp = lambda im: np.clip(im, 0, 1) ** (1 / 2.2)   # noqa: E731  (display-like domain)
    err = {}
    for n in (1, 2, 3):
        frames = supersampled_frames(cam, tracer, bundle, n, True)
        img = np.mean([fr.to_image(bundle.renderer.shade("sg", fr), bg) for fr, bg in frames],
                      axis=0)
        if n == 3:    # the stage's image is this average
            np.testing.assert_allclose(img, read_exr(out / "render" / "sg.exr"), atol=1e-6)
        d = (disp(img) - disp(ref)) ** 2
        err[n] = (np.sqrt(d[sil].mean()), np.sqrt(d[surf].mean()))
    assert err[2][0] < 0.75 * err[1][0] and err[3][0] < 0.9 * err[2][0], err
    assert abs(err[3][1] - err[1][1]) < 0.03 * err[1][1], err
