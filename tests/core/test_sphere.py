"""Point sets, Shirley–Chiu concentric map (area preservation), shading frames."""
import numpy as np
import pytest

from sgpipe.core import (concentric_square_to_hemisphere, concentric_texel_solid_angle,
                         fibonacci_sphere, gauss_legendre, hemisphere_to_concentric_square,
                         icosahedral_geodesic, latlong_dir, tangent_frame, to_local, to_world)

from .conftest import unit


def _cap_counts_uniformity(d, n_axes=40, seed=0):
    """Max over random caps of |fraction inside − cap area/4π| (spherical cap discrepancy)."""
    axes = unit(np.random.default_rng(seed).normal(size=(n_axes, 3)))
    worst = 0.0
    for h in [-0.5, 0.0, 0.3, 0.7, 0.9]:
        frac = np.mean(d @ axes.T >= h, axis=0)
        worst = max(worst, np.max(np.abs(frac - (1 - h) / 2)))
    return worst


def test_fibonacci_sphere():
    for n in [1, 2, 100, 2000]:
        d = fibonacci_sphere(n)
        assert d.shape == (n, 3)
        np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, rtol=1e-14)
    d = fibonacci_sphere(2000)
    assert np.linalg.norm(d.mean(axis=0)) < 1e-3
    # cap discrepancy of Fibonacci points is O(n^{-3/4}) ≈ 3.4e-3 here; iid points give ≈ 2e-2
    assert _cap_counts_uniformity(d) < 2 * 2000 ** -0.75
    iid = unit(np.random.default_rng(1).normal(size=(2000, 3)))
    assert _cap_counts_uniformity(iid) > 2 * 2000 ** -0.75
    np.testing.assert_array_equal(d, fibonacci_sphere(2000))


def test_icosahedral_geodesic():
    for f in [1, 2, 3, 4]:
        d = icosahedral_geodesic(f)
        assert d.shape == (10 * f * f + 2, 3)
        np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, rtol=1e-14)
        # no duplicates, centrally symmetric set
        dots = d @ d.T
        assert np.max(dots - 2 * np.eye(len(d))) < 1 - 1e-6
        assert np.all(np.max(d @ (-d).T, axis=1) > 1 - 1e-12)
    d = icosahedral_geodesic(3)
    assert len(d) == 92
    np.testing.assert_array_equal(d, icosahedral_geodesic(3))
    g = (1 + 5 ** 0.5) / 2
    np.testing.assert_allclose(d[0], unit([-1, g, 0]))
    # near-uniform spacing: nearest-neighbour angles within a narrow band
    ang = np.arccos(np.clip(np.sort(d @ d.T, axis=1)[:, -2], -1, 1))
    assert np.degrees(ang.min()) > 11.0 and ang.max() / ang.min() < 1.25
    assert np.linalg.norm(d.mean(axis=0)) < 1e-12


def test_concentric_roundtrip_and_range(rng):
    u, v = rng.random((2, 20000))
    d = concentric_square_to_hemisphere(u, v)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, rtol=1e-13)
    assert d[:, 2].min() >= 0.0
    u2, v2 = hemisphere_to_concentric_square(d)
    np.testing.assert_allclose(u2, u, atol=1e-12)
    np.testing.assert_allclose(v2, v, atol=1e-12)
    # corners / centre / edges
    np.testing.assert_allclose(concentric_square_to_hemisphere(0.5, 0.5), [0, 0, 1], atol=1e-15)
    for uu, vv in [(0, 0), (1, 0), (0, 1), (1, 1), (0.5, 0), (1, 0.5)]:
        assert concentric_square_to_hemisphere(uu, vv)[2] == pytest.approx(0.0, abs=1e-15)


def test_concentric_area_preserving():
    # |∂d/∂u × ∂d/∂v| = 2π everywhere (uniform hemisphere), by central differences
    g = np.linspace(0.013, 0.987, 41)
    U, V = np.meshgrid(g, g)
    U, V = U[np.abs(np.abs(2 * U - 1) - np.abs(2 * V - 1)) > 1e-3], V[np.abs(np.abs(2 * U - 1) - np.abs(2 * V - 1)) > 1e-3]
    h = 1e-6
    du = (concentric_square_to_hemisphere(U + h, V) - concentric_square_to_hemisphere(U - h, V)) / (2 * h)
    dv = (concentric_square_to_hemisphere(U, V + h) - concentric_square_to_hemisphere(U, V - h)) / (2 * h)
    np.testing.assert_allclose(np.linalg.norm(np.cross(du, dv), axis=-1), 2 * np.pi, rtol=1e-6)
    # texel solid angle: GL quadrature of the Jacobian over one texel equals 2π/res²
    res = 4
    x, w = gauss_legendre(4, 0.0, 1.0 / res)
    for i in range(res):
        for j in range(res):
            U, V = np.meshgrid(j / res + x, i / res + x)
            du = (concentric_square_to_hemisphere(U + h, V) - concentric_square_to_hemisphere(U - h, V)) / (2 * h)
            dv = (concentric_square_to_hemisphere(U, V + h) - concentric_square_to_hemisphere(U, V - h)) / (2 * h)
            om = np.sum(np.outer(w, w) * np.linalg.norm(np.cross(du, dv), axis=-1))
            assert om == pytest.approx(concentric_texel_solid_angle(res), rel=1e-6)
    # histogram of z for uniform (u, v) is uniform on [0, 1] (χ² with 20 bins)
    r = np.random.default_rng(7).random((2, 200000))
    z = concentric_square_to_hemisphere(*r)[:, 2]
    counts, _ = np.histogram(z, bins=20, range=(0, 1))
    chi2 = np.sum((counts - 1e4) ** 2 / 1e4)
    assert chi2 < 43.8            # p = 0.001 for 19 dof


def test_tangent_frame(rng):
    n = unit(rng.normal(size=(500, 3)))
    n[:4] = [[0, 1, 0], [0, -1, 0], [1e-12, 1, 0], [0, 0, 1]]
    n = unit(n)
    t, b = tangent_frame(n)
    for x in (t, b):
        np.testing.assert_allclose(np.linalg.norm(x, axis=-1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(np.sum(t * n, -1), 0.0, atol=1e-12)
    np.testing.assert_allclose(b, np.cross(n, t), atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(np.stack([t, b, n], -1)), 1.0, atol=1e-12)
    np.testing.assert_allclose(t[0], [1, 0, 0])
    np.testing.assert_allclose(t[1], [1, 0, 0])
    # default tangent = direction of increasing lat-long u (azimuth about +Y)
    u, v = 0.3, 0.4
    h = 1e-7
    dudir = unit(latlong_dir(u + h, v) - latlong_dir(u - h, v))
    t0, b0 = tangent_frame(latlong_dir(u, v))
    np.testing.assert_allclose(t0, dudir, atol=1e-7)
    assert np.dot(b0, latlong_dir(u, v + h) - latlong_dir(u, v - h)) > 0
    # hint
    th, _ = tangent_frame(n[5:], t_hint=[0.0, 0.0, 1.0])
    hint = np.array([0.0, 0.0, 1.0]) - n[5:, 2:3] * n[5:]
    np.testing.assert_allclose(th, unit(hint), atol=1e-12)
    # local ↔ world
    d = unit(rng.normal(size=(500, 3)))
    loc = to_local(d, n, t, b)
    np.testing.assert_allclose(to_world(loc, n, t, b), d, atol=1e-12)
    np.testing.assert_allclose(loc[:, 2], np.sum(d * n, -1), atol=1e-15)


def test_turn_frame_turns_the_tangent_towards_the_bitangent():
    """turn_frame: an orthonormal frame about the same normal, the tangent at `angle` from t
    towards b (a quarter turn takes t to b and b to −t), angles per row."""
    from sgpipe.core.sphere import tangent_frame, turn_frame
    rng = np.random.default_rng(3)
    n = unit(rng.normal(size=(200, 3)))
    t, b = tangent_frame(n)
    a = rng.uniform(-4.0, 4.0, 200)
    t2, b2 = turn_frame(t, b, a)
    np.testing.assert_allclose(np.sum(t2 * t, -1), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sum(t2 * b, -1), np.sin(a), atol=1e-12)
    np.testing.assert_allclose(np.cross(n, t2), b2, atol=1e-12)
    q, r = turn_frame(t, b, np.pi / 2)
    np.testing.assert_allclose(q, b, atol=1e-12)
    np.testing.assert_allclose(r, -t, atol=1e-12)
