"""Map I/O and conversions: lat-long ↔ cubemap ↔ dual paraboloid, seams, poles, bad input."""
import numpy as np
import pytest

from sgpipe.core.maps import (cubemap_texel_dirs, dual_paraboloid_solid_angles,
                              dual_paraboloid_valid_mask, latlong_solid_angles, latlong_texel_dirs)
from sgpipe.envmap import maps
from sgpipe.errors import BadInput
from sgpipe.io import write_exr


def smooth(d):
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([1 + 0.5 * x + 0.3 * y * z, 2 - 0.4 * y + 0.2 * x * x, 0.5 + 0.25 * z], -1)


def test_latlong_to_cube_preserves_smooth_function_and_power():
    ll = smooth(latlong_texel_dirs(128, 256))
    cube = maps.latlong_to_cubemap(ll, 32)
    np.testing.assert_allclose(cube, smooth(cubemap_texel_dirs(32)), atol=4e-3)
    p_ll = np.tensordot(latlong_solid_angles(128, 256), ll, axes=([0, 1], [0, 1]))
    np.testing.assert_allclose(maps.cubemap_power(cube), p_ll, rtol=1e-3)


def test_latlong_seam_and_poles_are_continuous():
    # a map that is smooth on the sphere but discontinuous in (u, v) if wrap/poles were wrong
    ll = smooth(latlong_texel_dirs(64, 128))
    cube = maps.latlong_to_cubemap(ll, 16)
    d = cubemap_texel_dirs(16)
    near_pole = np.abs(d[..., 1]) > 0.97
    near_seam = (np.abs(d[..., 0]) < 0.1) & (d[..., 2] < 0)          # u = 0 is −Z
    for m in (near_pole, near_seam):
        np.testing.assert_allclose(cube[m], smooth(d)[m], atol=6e-3)


def test_small_bright_source_keeps_its_power():
    ll = np.full((128, 256, 3), 0.1)
    ll[40, 77] = 5e4                     # one lat-long texel
    cube = maps.latlong_to_cubemap(ll, 64)
    p_ll = np.tensordot(latlong_solid_angles(128, 256), ll, axes=([0, 1], [0, 1]))
    np.testing.assert_allclose(maps.cubemap_power(cube), p_ll, rtol=0.03)


def test_cube_latlong_round_trip():
    cube = smooth(cubemap_texel_dirs(32))
    ll = maps.cubemap_to_latlong(cube, 48, 96)
    np.testing.assert_allclose(ll, smooth(latlong_texel_dirs(48, 96)), atol=4e-3)


@pytest.mark.parametrize("b", [1.0, 1.2])
def test_dual_paraboloid_conversions(b):
    cube = smooth(cubemap_texel_dirs(64))
    dp = maps.cubemap_to_dual_paraboloid(cube, 64, b)
    from sgpipe.core.maps import dual_paraboloid_texel_dirs
    np.testing.assert_allclose(dp, smooth(dual_paraboloid_texel_dirs(64, b)), atol=6e-3)
    # power with the exact DP texel solid angles over each map's own hemisphere
    om = dual_paraboloid_solid_angles(64, b) * dual_paraboloid_valid_mask(64, b)
    p_dp = np.tensordot(om, dp, axes=([0, 1, 2], [0, 1, 2]))
    np.testing.assert_allclose(p_dp, maps.cubemap_power(cube), rtol=2e-2)
    back = maps.dual_paraboloid_to_cubemap(dp, 32, b)
    np.testing.assert_allclose(back, smooth(cubemap_texel_dirs(32)), atol=1e-2)
    # seam between the two hemispheres (z = 0) is continuous
    d = np.array([[np.cos(a), np.sin(a), s * 1e-6] for a in np.linspace(0, 6, 25) for s in (1, -1)])
    v = maps.sample_dual_paraboloid(dp, d, b)
    np.testing.assert_allclose(v[0::2], v[1::2], atol=2e-2)


def test_cube_sampling_seamless_at_edges_and_corners():
    # the bordered per-face bilinear fetch agrees across seams to a small fraction of one
    # texel's variation (here |∇L|·h ≈ 0.05)
    cube = smooth(cubemap_texel_dirs(32))
    d = np.array([[1, 1, 0.3], [1, -1, 1], [-1, 1, 1], [0.2, 1, -1], [1, 1, 1], [-1, -1, -1]], float)
    eps = np.eye(3) * 1e-6
    for v in d:
        vals = [maps.sample_cubemap(cube, (v + e) / np.linalg.norm(v + e)) for e in eps]
        np.testing.assert_allclose(vals[0], vals[1], atol=3e-3)
        np.testing.assert_allclose(vals[0], vals[2], atol=3e-3)


def _write(tmp_path, name, img):
    p = tmp_path / name
    write_exr(p, img)
    return p


def test_bad_inputs_are_badinput_naming_file_and_key(tmp_path):
    with pytest.raises(BadInput) as e:
        maps.read_environment(tmp_path / "missing.exr")
    assert e.value.key == "envmap.environment" and "missing.exr" in e.value.file
    bad = np.ones((8, 16, 3), np.float32)
    bad[2, 3, 1] = np.nan
    with pytest.raises(BadInput, match="NaN"):
        maps.read_environment(_write(tmp_path, "nan.exr", bad))
    bad[2, 3, 1] = np.inf
    with pytest.raises(BadInput, match="NaN/Inf"):
        maps.read_environment(_write(tmp_path, "inf.exr", bad))
    with pytest.raises(BadInput, match="channels"):
        maps.read_environment(_write(tmp_path, "two.exr", np.ones((8, 16, 2), np.float32)))
    with pytest.raises(BadInput, match="negative"):
        maps.read_environment(_write(tmp_path, "neg.exr", -np.ones((8, 16, 3), np.float32)))
    rgba = np.ones((8, 16, 4), np.float32)
    rgba[..., 3] = 0.25
    assert maps.read_environment(_write(tmp_path, "rgba.exr", rgba)).shape == (8, 16, 3)
