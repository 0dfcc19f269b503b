"""glTF material textures: decoding (sRGB for base colour, linear metallic-roughness), the
bilinear lookup with glTF's top-left UV origin, wrap modes and KHR_texture_transform, and the
`reference` rendering a textured material point by point as the uniform material of that
texel's values."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sgpipe.errors import BadInput
from sgpipe.io.gltf import read_gltf
from sgpipe.io.gltf_textures import CLAMP, MIRROR, REPEAT, GltfTexture, material_texture
from sgpipe.io.png import srgb_to_linear

sys.path.insert(0, str(Path(__file__).parent))
import gltf_builder as gb  # noqa: E402

A, B = gb.HALF_A, gb.HALF_B
_halves = gb.halves


def test_decode_srgb_and_linear(tmp_path):
    mr = _halves([0, 0.25, 1.0], [0, 0.75, 0.0])
    doc = gb.textured_quad(_halves(A, B), mr)
    a = read_gltf(gb.write_glb(doc, tmp_path / "q.glb"))
    base = material_texture(a, 0, "baseColorTexture")
    np.testing.assert_allclose(base.image[0, 0, :3], srgb_to_linear(np.round(A * 255) / 255))
    rough_metal = material_texture(a, 0, "metallicRoughnessTexture")
    np.testing.assert_allclose(rough_metal.image[0, 0, 1:3], [64 / 255, 1.0])   # linear
    assert material_texture(a, 0, "normalTexture") is None
    # sgpipe UV (0.25, 0.5): the left half; glTF's v is 1 − v, rows from the top
    np.testing.assert_allclose(base.bilinear([[0.25, 0.5]])[0, :3], base.image[16, 8, :3])


def test_16_bit_grey_image_reads_as_three_channels(tmp_path):
    """A 16-bit single-channel PNG (roughness in every channel) gives G and B like RGB ones."""
    import io

    from PIL import Image
    from sgpipe.io.gltf_textures import _decode
    buf = io.BytesIO()
    Image.fromarray(np.full((4, 4), 32768, np.uint16)).save(buf, "PNG")
    img = _decode(buf.getvalue(), tmp_path / "x.glb", "images[0]")
    assert img.shape == (4, 4, 3)
    np.testing.assert_allclose(img[0, 0], 32768 / 65535)


def test_sRGB_curve():
    np.testing.assert_allclose(srgb_to_linear([0.0, 0.04045, 0.5, 1.0]),
                               [0.0, 0.04045 / 12.92, 0.214041140, 1.0], rtol=1e-6)


def test_wrap_modes_and_transform():
    img = np.arange(4.0)[None, :, None] * np.ones((1, 1, 1))   # 1 × 4 texels: 0 1 2 3
    uv = np.array([[1.125, 0.5], [-0.125, 0.5]])                # past the right / left edge
    at = lambda mode: GltfTexture(img, (mode, REPEAT)).bilinear(uv)[:, 0]  # noqa: E731
    np.testing.assert_allclose(at(REPEAT), [0.0, 3.0])          # wraps to the first / last
    np.testing.assert_allclose(at(CLAMP), [3.0, 0.0])
    np.testing.assert_allclose(at(MIRROR), [3.0, 0.0])
    # KHR_texture_transform: scale 2 along s maps u 0.3125 to 0.625 (texel 2's centre)
    m = np.diag([2.0, 1.0, 1.0])
    np.testing.assert_allclose(GltfTexture(img, (REPEAT, REPEAT), m).bilinear(
        [[0.3125, 0.5]])[0, 0], 2.0)


def test_bad_image_is_one_line(tmp_path):
    doc = gb.textured_quad(_halves(A, B))
    doc.images[0].bufferView = None
    doc.images[0].uri = "missing.png"
    a = read_gltf(gb.write_glb(doc, tmp_path / "q.glb"))
    with pytest.raises(BadInput) as e:
        material_texture(a, 0, "baseColorTexture")
    assert e.value.key == "images[0]" and "missing.png" in e.value.message


def _render(tmp_path, glb: Path, tag: str) -> np.ndarray:
    """The reference of the quad seen head-on under one point light (environment 2^-30):
    deterministic, each pixel the BRDF at its hit point times the light."""
    from sgpipe.io import read_exr
    studio = Path(__file__).resolve().parents[2] / "data_samples" / "studio.exr"
    cfg = tmp_path / f"{tag}.yaml"
    cfg.write_text(f"""
scene: {{gltf: [{{file: {glb}}}]}}
envmap: {{environment: {studio}, cube_resolution: 8}}
render:
  camera: {{eye: [0, 0, 3.0], target: [0, 0, 0], fov_deg: 30, width: 32, height: 32}}
  methods: [reference]
  environment_exposure: -30
  lights: [{{type: point, position: [0.6, 0.4, 1.5], intensity: [5, 5, 5], radius: 0.0}}]
  spp: 4
""")
    out = tmp_path / f"out_{tag}"
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(cfg), "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    return read_exr(out / "render" / "reference.exr")[..., :3]


def test_reference_reads_base_colour_and_metallic_roughness(tmp_path):
    """Left half: base A, roughness 0.3, dielectric; right half: base B, roughness 0.7,
    metal. Away from the seam every pixel equals the uniform material of its half."""
    tex, uniform = gb.halves_quads(tmp_path)
    img = _render(tmp_path, tex, "tex")
    half = {tag: _render(tmp_path, glb, tag) for tag, glb in uniform.items()}
    cols = np.arange(32)
    left, right = cols < 13, cols > 18               # the seam is at column 16
    rows = slice(6, 26)
    assert np.abs(img).max() > 0.05
    np.testing.assert_allclose(img[rows][:, left], half["a"][rows][:, left], rtol=1e-5,
                               atol=1e-6)
    np.testing.assert_allclose(img[rows][:, right], half["b"][rows][:, right], rtol=1e-5,
                               atol=1e-6)
    # and the two halves differ (the test could not pass by ignoring the textures)
    assert np.abs(half["a"][rows][:, left] - half["b"][rows][:, left]).max() > 0.05
