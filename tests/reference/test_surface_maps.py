"""The reference's texture and normal-map conventions (sgpipe.reference.surface) against the
kernels' (shading.h): OBJ uv with v = 0 the bottom row, texel centres, repeat addressing; the
normal-mapped frame as the shortest-arc rotation from +z; the kernels' view lift."""

import numpy as np

from sgpipe.reference import _sampling_jit as jit
from sgpipe.reference.surface import lift, mapped_view, normal_mapped_frame


def test_texture_lookup_convention():
    img = np.arange(2 * 4 * 1, dtype=float).reshape(2, 4, 1)      # rows 0 (top), 1 (bottom)
    uv = np.array([[0.125, 0.25], [0.125, 0.75], [0.375 + 1.0, 0.25 - 2.0], [0.0, 0.25]])
    got = jit.tex_bilinear(img, uv)[:, 0]
    # bottom-left texel centre, top-left, repeat of the bottom row's 2nd texel, the u seam
    # halfway between the last and first bottom texels
    np.testing.assert_allclose(got, [4.0, 0.0, 5.0, 0.5 * (4.0 + 7.0)])


def test_normal_mapped_frame_is_the_shortest_arc():
    t = np.array([[1.0, 0, 0]] * 3)
    b = np.array([[0, 0, -1.0]] * 3)
    n = np.array([[0, 1.0, 0]] * 3)                 # b = n × t
    a = 0.4
    nl = np.array([[0, 0, 1.0], [np.sin(a), 0, np.cos(a)], [0.3, -0.5, 0.81]])
    nl /= np.linalg.norm(nl, axis=1, keepdims=True)
    t2, b2, n2 = normal_mapped_frame(t, b, n, 0.5 * nl + 0.5)
    np.testing.assert_allclose(n2, nl[:, :1] * t + nl[:, 1:2] * b + nl[:, 2:] * n, atol=1e-12)
    np.testing.assert_allclose(np.cross(n2, t2), b2, atol=1e-12)            # right-handed
    np.testing.assert_allclose((t2, b2, n2)[0][0], t[0], atol=1e-12)        # flat: unchanged
    # a tilt towards t rotates about b: t' = cos a·t − sin a·n, b' = b
    np.testing.assert_allclose(t2[1], np.cos(a) * t[1] - np.sin(a) * n[1], atol=1e-12)
    np.testing.assert_allclose(b2[1], b[1], atol=1e-12)
    # the rotation axis (z × n') is left fixed
    axis = np.cross([0, 0, 1.0], nl[2])
    w = axis[0] * t[2] + axis[1] * b[2] + axis[2] * n[2]
    rot = np.stack([t2[2], b2[2], n2[2]], -1)           # columns: images of t, b, n
    base = np.stack([t[2], b[2], n[2]], -1)
    np.testing.assert_allclose(rot @ (base.T @ w), w, atol=1e-12)


def test_view_lift_keeps_grazing_views():
    d = np.array([[0.6, 0.0, 0.8], [0.0, 1.0, -0.2]])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    out = lift(d, 0.01)
    np.testing.assert_array_equal(out[0], d[0])
    np.testing.assert_allclose(out[1], [0, np.sqrt(1 - 1e-4), 0.01])
    # a mapped normal tilted away from the viewer: the view stays 0.01 above the mapped horizon
    t, b, n = np.array([[1.0, 0, 0]]), np.array([[0, 0, -1.0]]), np.array([[0, 1.0, 0]])
    view = np.array([[-np.sin(1.2), np.cos(1.2), 0.0]])
    t2, b2, n2 = normal_mapped_frame(t, b, n, 0.5 * np.array([[0.8, 0, 0.6]]) + 0.5)
    v2 = mapped_view(view, t, b, n, t2, b2, n2)
    assert np.einsum("ij,ij->i", view, n2)[0] < 0
    np.testing.assert_allclose(np.einsum("ij,ij->i", v2, n2), 0.01, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(v2, axis=1), 1.0, atol=1e-12)


def test_backfacing_black_zeroes_only_views_behind_the_mapped_normal(tmp_path):
    """render.reference_mapped_backfacing: v-grooves tilted ±45° along t (+X), seen 20° above the
    plane from +X: with `black` the pixels whose centre sees a face turned away are 0 (Mitsuba's
    `normalmap`), every other pixel is the `lift` value to the bit (same sample streams)."""
    import dataclasses
    from pathlib import Path

    from sgpipe.experiments.corpus.assets import vgroove_normals, write_normal_map
    from sgpipe.experiments.corpus.measure import load_scene
    from sgpipe.stages.render import reference_from_config

    data = Path(__file__).resolve().parents[2] / "data_samples"
    nmap = write_normal_map(tmp_path / "vg.exr", vgroove_normals(16, 8, 45.0))
    el = np.radians(20.0)
    cfg = load_scene({
        "name": "backfacing", "seed": 3,
        "scene": {"objects": [{"name": "p", "mesh": str(data / "floor.obj"), "material": "m",
                               "normal_map": str(nmap), "uv_repeat": [4.0, 4.0]}]},
        "fit": {"materials": [{"name": "m", "model": "beckmann",
                               "params": {"alpha": 0.3, "ks": 0.5, "kd": 0.3}}]},
        "envmap": {"environment": str(data / "white.exr")},
        "render": {"camera": {"eye": [3.0 * np.cos(el), 3.0 * np.sin(el), 0.0],
                              "target": [0.0, 0.0, 0.0], "fov_deg": 20.0, "width": 24,
                              "height": 24},
                   "methods": ["reference"], "spp": 4, "background": False,
                   "pixel_filter": {"type": "center"}}})
    img = {}
    for mode in ("lift", "black"):
        rs = dataclasses.replace(cfg.render, reference_mapped_backfacing=mode)
        img[mode] = reference_from_config(dataclasses.replace(cfg, render=rs)).image[..., :3]
    lit, black = img["lift"], img["black"]
    zero = (black == 0).all(axis=-1)
    same = (black == lit).all(axis=-1)
    assert (zero | same).all()
    assert (zero & (lit > 0).all(axis=-1)).sum() > 20      # faces turned away: lift shades them
    assert (same & (lit > 0).all(axis=-1)).sum() > 20      # faces towards the view: untouched
