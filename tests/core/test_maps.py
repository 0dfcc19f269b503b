"""Lat-long (docs/CONVENTIONS.md), OpenGL cubemap and dual-paraboloid maps: conventions, round trips, solid angles."""
import numpy as np
import pytest

from sgpipe.core import (cubemap_dir, cubemap_solid_angles, cubemap_texel_dirs, dir_to_cubemap,
                         dir_to_dual_paraboloid, dir_to_latlong, dual_paraboloid_dir,
                         dual_paraboloid_distortion, dual_paraboloid_solid_angles,
                         dual_paraboloid_texel_dirs, dual_paraboloid_valid_mask, gauss_legendre,
                         latlong_dir, latlong_solid_angles, latlong_texel_dirs)

from .conftest import unit


def _texel_solid_angle_numeric(fmap, s0, s1, t0, t1, order=6, h=1e-6):
    """∫∫ |∂d/∂s × ∂d/∂t| ds dt over one texel by GL + central differences (independent of the code)."""
    xs, ws = gauss_legendre(order, s0, s1)
    xt, wt = gauss_legendre(order, t0, t1)
    S, T = np.meshgrid(xs, xt)
    ds = (fmap(S + h, T) - fmap(S - h, T)) / (2 * h)
    dt = (fmap(S, T + h) - fmap(S, T - h)) / (2 * h)
    return np.sum(np.outer(wt, ws) * np.linalg.norm(np.cross(ds, dt), axis=-1))


def test_latlong_conventions_and_roundtrip(rng):
    np.testing.assert_allclose(latlong_dir(0.3, 0.0), [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(latlong_dir(0.0, 0.5), [0, 0, -1], atol=1e-15)
    np.testing.assert_allclose(latlong_dir(0.5, 0.5), [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(latlong_dir(0.25, 0.5), [1, 0, 0], atol=1e-15)
    d = latlong_texel_dirs(8, 16)
    assert d.shape == (8, 16, 3) and d[0, 0, 1] > 0.9
    u, v = rng.random((2, 5000))
    u2, v2 = dir_to_latlong(latlong_dir(u, v))
    np.testing.assert_allclose(u2, u, atol=1e-12)
    np.testing.assert_allclose(v2, v, atol=1e-12)


def test_latlong_solid_angles():
    for h, w in [(1, 2), (16, 32), (128, 256)]:
        assert latlong_solid_angles(h, w).sum() == pytest.approx(4 * np.pi, rel=1e-13)
    h, w = 6, 12
    om = latlong_solid_angles(h, w)
    for i in range(h):
        num = _texel_solid_angle_numeric(latlong_dir, 0.0, 1 / w, i / h, (i + 1) / h)
        assert om[i, 3] == pytest.approx(num, rel=1e-8)


def test_cubemap_opengl_orientation():
    c = 1 / np.sqrt(3)
    # OpenGL spec table: (face, s=0, t=0) corner directions
    expect = {0: [1, 1, 1], 1: [-1, 1, -1], 2: [-1, 1, -1], 3: [-1, -1, 1], 4: [-1, 1, 1], 5: [1, 1, -1]}
    for f, e in expect.items():
        np.testing.assert_allclose(cubemap_dir(f, 0.0, 0.0), np.array(e) * c, atol=1e-15)
    axes = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.0]])
    for f in range(6):
        np.testing.assert_allclose(cubemap_dir(f, 0.5, 0.5), axes[f], atol=1e-15)
        face, s, t = dir_to_cubemap(axes[f])
        assert face == f and s == 0.5 and t == 0.5


def test_cubemap_roundtrip_and_solid_angles(rng):
    d = unit(rng.normal(size=(20000, 3)))
    f, s, t = dir_to_cubemap(d)
    np.testing.assert_allclose(cubemap_dir(f, s, t), d, atol=1e-12)
    assert np.all((s >= 0) & (s <= 1) & (t >= 0) & (t <= 1))
    td = cubemap_texel_dirs(8)
    f, s, t = dir_to_cubemap(td)
    np.testing.assert_array_equal(f, np.broadcast_to(np.arange(6)[:, None, None], f.shape))
    c = (np.arange(8) + 0.5) / 8
    np.testing.assert_allclose(s, np.broadcast_to(c[None, None, :], s.shape), atol=1e-14)
    np.testing.assert_allclose(t, np.broadcast_to(c[None, :, None], t.shape), atol=1e-14)
    for res in [1, 7, 64]:
        assert cubemap_solid_angles(res).sum() == pytest.approx(4 * np.pi, rel=1e-13)
    res = 5
    om = cubemap_solid_angles(res)
    for f in [0, 3, 5]:
        for i, j in [(0, 0), (2, 3), (4, 1)]:
            num = _texel_solid_angle_numeric(lambda s, t: cubemap_dir(f, s, t), j / res, (j + 1) / res,
                                             i / res, (i + 1) / res)
            assert om[f, i, j] == pytest.approx(num, rel=1e-8)


@pytest.mark.parametrize("b", [1.0, 1.2])
def test_dual_paraboloid(rng, b):
    d = unit(rng.normal(size=(20000, 3)))
    hemi, s, t = dir_to_dual_paraboloid(d, b)
    np.testing.assert_allclose(dual_paraboloid_dir(hemi, s, t, b), d, atol=1e-12)
    assert np.all(hemi == (d[:, 2] < 0))
    # inside its hemisphere every direction lands in the inscribed disk of radius 1/b
    r = np.hypot(2 * s - 1, 2 * t - 1)
    assert r.max() <= 1 / b + 1e-12
    np.testing.assert_allclose(dual_paraboloid_dir(0, 0.5, 0.5, b), [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(dual_paraboloid_dir(1, 0.5, 0.5, b), [0, 0, -1], atol=1e-15)
    assert dual_paraboloid_dir(0, 0.5, 0.0, b)[1] > 0          # row 0 is +Y
    res = 6
    om = dual_paraboloid_solid_angles(res, b)
    for hm in (0, 1):
        for i, j in [(0, 0), (2, 3), (5, 1)]:
            num = _texel_solid_angle_numeric(lambda s, t: dual_paraboloid_dir(hm, s, t, b),
                                             j / res, (j + 1) / res, i / res, (i + 1) / res)
            assert om[hm, i, j] == pytest.approx(num, rel=1e-8)
    # Töral19 eq 9 / 11: Ω_texel ≈ d(i)/(w·h) at the texel centre (midpoint rule, O(1/res²))
    res = 256
    om = dual_paraboloid_solid_angles(res, b)
    dirs = dual_paraboloid_texel_dirs(res, b)
    dist = dual_paraboloid_distortion(dirs, b) / res**2
    mask = dual_paraboloid_valid_mask(res, b)
    np.testing.assert_allclose(om[mask], dist[mask], rtol=5e-5)
    # |i_z| makes eq 11 valid only inside the map's own hemisphere; past the equator (b > 1
    # corners) the factor is 4b²(1 ± i_z)² with the map's own sign
    sgn = np.array([1.0, -1.0])[:, None, None]
    np.testing.assert_allclose(om, 4 * b * b * (1 + sgn * dirs[..., 2]) ** 2 / res**2, rtol=5e-5)
    # texels whose centre lies in their own hemisphere tile the sphere (boundary error O(1/res))
    assert om[mask].sum() == pytest.approx(4 * np.pi, rel=1.5 / res)
    # whole square of one map vs an independent 200×200 Gauss–Legendre rule
    xs, ws = gauss_legendre(200, -1.0, 1.0)
    X, Y = np.meshgrid(xs, xs)
    full = np.sum(np.outer(ws, ws) * 4 * b * b / (1 + b * b * (X * X + Y * Y)) ** 2)
    assert om[0].sum() == pytest.approx(full, rel=1e-10)
