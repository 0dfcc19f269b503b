"""glTF normal textures in the reference, sg and fis: the texture's normal in the tangent frame
(TANGENT, else MikkTSpace; bitangent w (n × t)), with its `scale`, renders as the same normal
given as geometry."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import gltf_builder as gb  # noqa: E402

METHODS = ("sg", "fis", "reference")


def _render(tmp_path, glb: Path, tag: str, visibility: bool = False) -> dict:
    """sg, fis and the reference under a point light; `visibility`: with the SSDF stage (the
    renderer then reads the meshes, handedness included, from its geometry.npz)."""
    from sgpipe.io import read_exr
    cfg = tmp_path / f"{tag}.yaml"
    vis = "visibility: {trace_resolution: 16, resolution: 8, pca_terms: 4}" if visibility else ""
    cfg.write_text(f"""
{vis}
scene: {{gltf: [{{file: {glb}}}]}}
fit: {{view_gmm: {{enabled: false}}}}
render:
  camera: {{eye: [0, 0, 3.0], target: [0, 0, 0], fov_deg: 40, width: 32, height: 32}}
  methods: [{', '.join(METHODS)}]
  fis_samples: 64
  spp: 4
  lights: [{{type: point, position: [0.6, 0.4, 1.5], intensity: [5, 5, 5], radius: 0.0}}]
""")
    out = tmp_path / f"out_{tag}"
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(cfg), "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    return {m: read_exr(out / "render" / f"{m}.exr")[..., :3] for m in METHODS}


@pytest.mark.parametrize("given", ["mikktspace", "tangent"])
def test_normal_texture_renders_as_the_normal_it_encodes(tmp_path, given):
    """A square whose halves mirror the texture (u = |x|): on the right half the texture's +X
    runs along +x, on the left along −x, and on both its +Y (up in the image) along +y. The
    same square with the decoded normal as geometry (x mirrored on the left) renders the same
    in every method; under the texture's `scale` s the normal is (s x, s y, z)."""
    textured, baked, flipped = gb.tilted_strips(tmp_path, given)
    vis = given == "tangent"         # one variant through the visibility stage's geometry
    got = _render(tmp_path, textured, "tex", vis)
    want = _render(tmp_path, baked, "baked", vis)
    rows = slice(6, 26)
    for method in METHODS:
        a, b = got[method][rows], want[method][rows]
        assert np.abs(b).mean() > 0.02
        err = np.abs(a - b).mean() / np.abs(b).mean()
        assert err <= 2e-3, (method, err)
    # the bitangent's sign matters here: with +Y along n × t on the left half (w ignored)
    # that half would render as the normal (−x, −y, z), far outside the tolerance
    wrong = _render(tmp_path, flipped, "flipped", vis)["sg"][rows]
    b = want["sg"][rows]
    assert np.abs(wrong - b).mean() / np.abs(b).mean() > 0.05


def test_anisotropy_rotation_turns_towards_the_handed_bitangent(tmp_path):
    """KHR_materials_anisotropy's rotation θ turns the anisotropy direction from TANGENT towards
    the bitangent w (n × t): on the mirrored strip (left half t = −x, w = −1; right t = +x,
    w = 1; both bitangents +y) a rotation of 0.8 rad renders, in every method, as the same strip
    with its TANGENTs given as the turned directions (∓cos θ, sin θ) and no rotation; turning
    the left half the other way (w ignored) does not."""
    th = 0.8
    c, s = np.cos(th), np.sin(th)
    ext = lambda rot: {"KHR_materials_anisotropy": {"anisotropyStrength": 0.9,   # noqa: E731
                                                   "anisotropyRotation": rot}}

    def strip(tangents, rot, name):
        doc = gb.mirrored_strip(tangents=tangents, roughness=0.3)
        doc.materials[0].extensions = ext(rot)
        return gb.write_glb(doc, tmp_path / f"{name}.glb")

    turned = _render(tmp_path, strip([[-1, 0, 0, -1], [1, 0, 0, 1]], th, "turned"), "turned")
    given = _render(tmp_path, strip([[-c, s, 0, -1], [c, s, 0, 1]], 0.0, "given"), "given")
    unhanded = _render(tmp_path, strip([[-c, -s, 0, -1], [c, s, 0, 1]], 0.0, "unhanded"),
                       "unhanded")
    rows = slice(6, 26)
    for method in METHODS:
        a, b = turned[method][rows], given[method][rows]
        assert np.abs(b).mean() > 0.02
        assert np.abs(a - b).mean() / np.abs(b).mean() <= 2e-3, method
    left = (rows, slice(0, 16))
    b = given["sg"][left]
    assert np.abs(unhanded["sg"][left] - b).mean() / np.abs(b).mean() > 0.05


def _aniso_texel(angle: float, strength: float) -> np.ndarray:
    """The 8-bit texel of a direction angle and strength, and what it decodes to."""
    c = np.round((np.array([np.cos(angle), np.sin(angle)]) + 1.0) / 2.0 * 255.0) / 255.0
    b = np.round(strength * 255.0) / 255.0
    return np.array([c[0], c[1], b])


def test_anisotropy_texture_direction_adds_to_the_rotation(tmp_path):
    """KHR_materials_anisotropy's texture: a constant direction φ (RG = (cos φ, sin φ)) with
    rotation θ renders, in every method, as the factor's rotation θ + φ without the texture
    (φ as its 8-bit texel decodes); its strength B scales the factor's: in the reference and
    fis (exact BRDF per pixel) as the factor × B without the texture."""
    phi, th = 0.9, -0.3
    texel = _aniso_texel(phi, 1.0)
    d = 2.0 * texel[:2] - 1.0
    phi_q = float(np.arctan2(d[1], d[0]))
    img = np.tile(texel, (4, 4, 1))

    def strip(name, rot, strength=0.9, image=None):
        doc = gb.mirrored_strip(tangents=[[-1, 0, 0, -1], [1, 0, 0, 1]], roughness=0.3)
        return gb.write_glb(gb.add_anisotropy(doc, strength, rot, image), tmp_path / f"{name}.glb")

    textured = _render(tmp_path, strip("textured", th, image=img), "textured")
    turned = _render(tmp_path, strip("turned", th + phi_q), "turned")
    plain = _render(tmp_path, strip("plain", th), "plain")
    rows = slice(6, 26)
    for method in METHODS:
        a, b = textured[method][rows], turned[method][rows]
        assert np.abs(b).mean() > 0.02
        assert np.abs(a - b).mean() / np.abs(b).mean() <= 2e-3, method
        # the direction matters here (the test can fail)
        c = plain[method][rows]
        assert np.abs(c - b).mean() / np.abs(b).mean() > 0.02, method
    half = _aniso_texel(0.0, 0.5)
    weak = _render(tmp_path, strip("weak", th, image=np.tile(half, (4, 4, 1))), "weak")
    scaled = _render(tmp_path, strip("scaled", th, strength=0.9 * half[2]), "scaled")
    for method in ("reference", "fis"):
        a, b = weak[method][rows], scaled[method][rows]
        assert np.abs(a - b).mean() / np.abs(b).mean() <= 2e-3, method
        c = plain[method][rows]
        assert np.abs(c - b).mean() / np.abs(b).mean() > 0.02, method
