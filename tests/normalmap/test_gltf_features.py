"""Han07 eq 22 on a glTF material: the base-colour and metallic-roughness textures as the vMF
lobes' features (kd, F0, ln roughness), each lobe shaded with its own colour, F0 and roughness
(eq 21 at the lobe's roughness)."""

from __future__ import annotations

import numpy as np
from pygltflib import REPEAT

from tests.scene import gltf_builder as gb

#: the two stripe materials: base colour (sRGB), roughness, metallic; and their normals' x
STRIPES = {"a": (gb.HALF_A, 0.35, 0.0, 1.0), "b": (gb.HALF_B, 0.8, 1.0, -1.0)}
SIDE = 256
WIDTH = 8                   # texels per stripe
TILT_X = np.sin(np.pi / 6)


def _normal_colour(sign: float) -> np.ndarray:
    return (np.array([sign * TILT_X, 0.0, np.cos(np.pi / 6)]) + 1.0) / 2.0


def striped_quads(folder):
    """The quad with SIDE² textures in WIDTH-texel columns alternating between the two STRIPES
    (normal tilted 30° towards +x / −x, each its own base colour, roughness and metalness),
    and per stripe the quad of its material and constant normal texture alone: (striped .glb,
    {"a": .glb, "b": .glb})."""
    from sgpipe.io.png import srgb_to_linear
    cols = np.arange(SIDE) // WIDTH % 2 == 0
    img = {k: np.empty((SIDE, SIDE, 3)) for k in ("base", "mr", "normal")}
    for sel, (c, r, m, sx) in ((cols, STRIPES["a"]), (~cols, STRIPES["b"])):
        img["base"][:, sel] = c
        img["mr"][:, sel] = (0.0, r, m)
        img["normal"][:, sel] = _normal_colour(sx)
    striped = gb.write_glb(gb.textured_quad(img["base"], img["mr"], normal_img=img["normal"],
                                            wrap=REPEAT), folder / "striped.glb")
    alone = {}
    for tag, (c, r, m, sx) in STRIPES.items():
        lin = srgb_to_linear(np.round(np.asarray(c) * 255) / 255)    # the PNG's 8 bits
        doc = gb.textured_quad(normal_img=np.tile(_normal_colour(sx), (4, 4, 1)),
                               base=tuple(lin), metallic=m, roughness=np.round(r * 255) / 255,
                               wrap=REPEAT)
        alone[tag] = gb.write_glb(doc, folder / f"{tag}.glb")
    return striped, alone


NM = "normalmap: {{lobes: 2, sh_order: 2, colour_features: {}}}\n"
INNER = (slice(6, 26), slice(6, 26))


def _rel(a, b) -> float:
    return float(np.abs(a[INNER] - b[INNER]).mean() / np.abs(b[INNER]).mean())


def test_lobes_take_their_own_colour_f0_and_roughness_under_a_light(tmp_path):
    """Minified (≈ 10 texels a pixel, a stripe pair per 1.6 pixels) under a point light: vmf
    with the features — two sharp lobes, each its stripe's colour, F0 and roughness — is
    within 9 % of the reference (256 spp); with the pixel's filtered material (features
    off) ≥ 13 % off."""
    striped, _ = striped_quads(tmp_path)
    got = gb.render_quad(tmp_path, striped, "feat", ("vmf", "reference"), light=True,
                         sections=NM.format("true"), render="  spp: 256\n")
    plain = gb.render_quad(tmp_path, striped, "plain", ("vmf",), light=True,
                           sections=NM.format("false"))["vmf"]
    ref = got["reference"]
    assert np.abs(ref[INNER]).mean() > 0.05
    err, off = _rel(got["vmf"], ref), _rel(plain, ref)
    assert err <= 0.09, err
    assert off >= 0.13, off


def test_lobes_take_their_own_colour_f0_and_roughness_under_the_environment(tmp_path):
    """Under the studio map the striped quad's mean over the frame's middle is the mean of
    the two stripes' own renders (each its material with its constant normal texture, the
    same method) within 2 % per channel with the features; the pixel's filtered material is
    ≥ 4 % off in some channel (the metal stripe's blue)."""
    striped, alone = striped_quads(tmp_path)
    got = gb.render_quad(tmp_path, striped, "feat", ("vmf",), light=False,
                         sections=NM.format("true"))["vmf"]
    plain = gb.render_quad(tmp_path, striped, "plain", ("vmf",), light=False,
                           sections=NM.format("false"))["vmf"]
    each = [gb.render_quad(tmp_path, glb, tag, ("vmf",), light=False,
                           sections=NM.format("false"))["vmf"] for tag, glb in alone.items()]
    want = (0.5 * (each[0] + each[1]))[INNER].mean((0, 1))
    assert want.min() > 1e-3
    err = np.abs(got[INNER].mean((0, 1)) - want) / want
    off = np.abs(plain[INNER].mean((0, 1)) - want) / want
    assert err.max() <= 0.02, err
    assert off.max() >= 0.04, off


def test_stage_stores_the_material_features(tmp_path):
    """The normalmap stage's vmf.npz for a glTF material with base-colour and
    metallic-roughness textures: feature_names kd, F0, ln roughness; at level 0 each texel's
    own (8-bit) values; at level 1 each lobe its stripe's (the clusters do not mix)."""
    from sgpipe.artifacts.normalmap import GLTF_FEATURE_NAMES, read_vmf
    from sgpipe.io.png import srgb_to_linear
    striped, _ = striped_quads(tmp_path)
    gb.render_quad(tmp_path, striped, "feat", ("vmf",), light=True,
                   sections=NM.format("true"))
    nm_dir = tmp_path / "out_feat" / "normalmap"
    name = next(p.name for p in nm_dir.iterdir() if p.is_dir())
    v = read_vmf(nm_dir, name)
    assert v.feature_names == GLTF_FEATURE_NAMES
    want = {}
    for tag, (c, r, m, sx) in STRIPES.items():
        lin = srgb_to_linear(np.round(np.asarray(c) * 255) / 255)
        rr = np.round(r * 255) / 255
        want[sx] = np.concatenate([(1 - m) * lin, (1 - m) * 0.04 + m * lin,
                                   [np.log(max(rr, 0.06))]])
    a0, f0 = v.alpha[0], v.alpha_f[0]
    j = np.argmax(a0, axis=2)                         # level 0: each texel one lobe
    f_texel = np.take_along_axis(f0, j[..., None, None], 2)[..., 0, :]
    assert np.allclose(f_texel[:, 0], want[1.0], atol=2e-3)
    assert np.allclose(f_texel[:, WIDTH], want[-1.0], atol=2e-3)
    a1, ar1, f1 = v.alpha[1], v.alpha_r[1], v.alpha_f[1]
    for lobe in range(2):
        used = a1[..., lobe] > 0                      # inside a stripe one lobe is empty
        sx = np.sign(ar1[..., lobe, 0])[used]
        feat = f1[..., lobe, :][used] / a1[..., lobe][used][:, None]
        for s in (1.0, -1.0):
            assert (sx == s).any()
            assert np.allclose(feat[sx == s], want[s], atol=2e-3)


def test_transformed_textures_are_sampled_through_their_transform():
    """Features of random base-colour / metallic-roughness textures: read by sampling
    (`sampled_linear`) they equal the box means of the per-texel kd, F0, ln r; under a
    KHR_texture_transform of scale 2 the map of twice the side holds them twice per axis
    (the textures repeat in its UV square); per-texel products, not products of means."""
    from dataclasses import replace

    from sgpipe.io.gltf_textures import GltfTexture
    from sgpipe.normalmap import features as F
    from sgpipe.render.materials import GltfFactors
    rng = np.random.default_rng(3)
    base, mr = GltfTexture(rng.random((64, 64, 3))), GltfTexture(rng.random((64, 64, 3)))
    params = {"base_color": [1.0, 0.5, 0.25], "metallic": 0.9, "roughness": 0.8}
    exact = F.gltf_map_features(params, base, mr, 16)
    g = GltfFactors.of_params(params)
    assert np.allclose(F.sampled_linear(g, base, mr, 16), exact, atol=1e-12)
    scale2 = np.diag([2.0, 2.0, 1.0])
    tiled = F.gltf_map_features(params, replace(base, matrix=scale2),
                                replace(mr, matrix=scale2), 32)
    for rows in (slice(0, 16), slice(16, 32)):
        for cols in (slice(0, 16), slice(16, 32)):
            assert np.allclose(tiled[rows, cols], exact, atol=1e-12)
    c = np.asarray(params["base_color"]) * base.image.reshape(16, 4, 16, 4, 3).mean((1, 3))
    m = np.clip(0.9 * mr.image[..., 2].reshape(16, 4, 16, 4).mean((1, 3)), 0, 1)[..., None]
    assert np.abs(exact[..., :3] - (1 - m) * c).max() > 1e-3     # products of means differ
