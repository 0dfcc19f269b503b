"""Emission (glTF emissiveFactor × emissiveTexture × KHR_materials_emissive_strength, and the
`gltf_pbr` material's `emissive`): every method adds what the surface emits to what it
reflects."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import gltf_builder as gb  # noqa: E402

METHODS = ("sg", "fis", "gmm", "reference")
FACTOR, STRENGTH = np.array([0.6, 0.3, 0.9]), 2.5
#: the emissive texture's halves (sRGB)
LEFT, RIGHT = np.array([0.9, 0.5, 0.2]), np.array([0.2, 0.7, 0.4])


LIGHT = "[{type: point, position: [0.6, 0.4, 1.5], intensity: [5, 5, 5], radius: 0.0}]"


def _render(tmp_path, scene: str, tag: str, lights: str = LIGHT) -> dict:
    from sgpipe.io import read_exr
    cfg = tmp_path / f"{tag}.yaml"
    cfg.write_text(f"""
{scene}
render:
  camera: {{eye: [0, 0, 3.0], target: [0, 0, 0], fov_deg: 40, width: 32, height: 32}}
  methods: [{', '.join(METHODS)}]
  fis_samples: 64
  spp: 4
  lights: {lights}
""")
    out = tmp_path / f"out_{tag}"
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(cfg), "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    return {m: read_exr(out / "render" / f"{m}.exr")[..., :3] for m in METHODS}


def _quad(folder: Path, name: str, **kw) -> Path:
    p = np.array([[-1, 1, 0], [1, 1, 0], [1, -1, 0], [-1, -1, 0]], np.float32)
    n = np.array([[0, 0, 1]] * 4, np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    idx = np.array([0, 3, 2, 0, 2, 1])
    return gb.write_glb(gb.primitive_doc(p, n, uv, idx, kw.pop("images", {}), base=(0.5,) * 3,
                                         metallic=0.0, roughness=0.5, **kw),
                        folder / f"{name}.glb")


def test_emissive_texture_adds_its_radiance(tmp_path):
    """The lit quad with an emissive texture (two halves), factor and strength minus the same
    quad without them is factor × strength × the texel (sRGB-decoded) in every method."""
    from sgpipe.io.png import srgb_to_linear
    img = gb.halves(LEFT, RIGHT)
    glow = _quad(tmp_path, "glow", images={"emissiveTexture": img}, emissive=FACTOR,
                 emissive_strength=STRENGTH)
    plain = _quad(tmp_path, "plain")
    a = _render(tmp_path, f"scene: {{gltf: [{{file: {glow}}}]}}", "glow")
    b = _render(tmp_path, f"scene: {{gltf: [{{file: {plain}}}]}}", "plain")
    rows = slice(8, 24)
    for method in METHODS:
        d = (a[method] - b[method])[rows]
        for cols, c in ((slice(4, 13), LEFT), (slice(19, 28), RIGHT)):
            want = FACTOR * STRENGTH * srgb_to_linear(np.round(c * 255) / 255)
            np.testing.assert_allclose(d[:, cols].reshape(-1, 3).mean(0), want, rtol=2e-3,
                                       err_msg=method)
            assert np.abs(d[:, cols] - want).max() < 5e-3 * want.max(), method


def test_gltf_pbr_emissive_parameter(tmp_path):
    """A YAML `gltf_pbr` material's `emissive` in the dark (no light, no environment): each
    method sees exactly the emitted radiance on the surface and nothing elsewhere."""
    sphere = Path(__file__).resolve().parents[2] / "data_samples" / "sphere.obj"
    scene = f"""scene: {{objects: [{{name: ball, mesh: {sphere}, material: lamp}}]}}
fit:
  materials: [{{name: lamp, model: gltf_pbr, params: {{base_color: 0.5, metallic: 0.0,
              roughness: 0.5, emissive: [0.25, 0.5, 1.5]}}}}]"""
    got = _render(tmp_path, scene, "lamp", lights="[]")
    hit = got["sg"].max(-1) > 0
    assert 100 < hit.sum() < hit.size
    inner = hit.copy()            # pixels the sphere covers whole (the reference's box filter)
    for ax in (0, 1):
        for step in (1, -1):
            inner &= np.roll(hit, step, axis=ax)
    for method in METHODS:
        img = got[method]
        assert (img[~hit] == 0).all() if method != "reference" else (img[~hit] < 1.5).all()
        sel = hit if method != "reference" else inner
        np.testing.assert_allclose(img[sel], np.tile([0.25, 0.5, 1.5], (sel.sum(), 1)),
                                   rtol=1e-5, err_msg=method)
