"""Textures and normal maps are data: an RGBA PNG's alpha must not scale its RGB."""

import numpy as np
import OpenImageIO as oiio

from sgpipe.render.setup import read_texture


def _write_rgba_png(path, rgba_u8):
    out = oiio.ImageOutput.create(str(path))
    spec = oiio.ImageSpec(rgba_u8.shape[1], rgba_u8.shape[0], 4, oiio.UINT8)
    spec.attribute("oiio:UnassociatedAlpha", 1)
    out.open(str(path), spec)
    out.write_image(rgba_u8)
    out.close()


def test_png_alpha_does_not_premultiply_the_texels(tmp_path):
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 0], rgba[..., 1], rgba[..., 2] = 128, 128, 255   # the flat normal (0, 0, 1)
    rgba[..., 3] = [[0, 64], [128, 255]]
    path = tmp_path / "normal_rgba.png"
    _write_rgba_png(path, rgba)
    tex = read_texture(path, "scene.objects.0.normal_map")
    assert np.allclose(tex, rgba[..., :3] / 255.0, atol=1e-6)
