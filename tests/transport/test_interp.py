"""Interpolating Gaussian parameters across views: a lobe rotated between views stays one
lobe, rotated — not a cross-fade of three (Green06 §3.2, Fig 2)."""

import numpy as np
import pytest

from sgpipe.core.rotation import axis_angle_matrix
from sgpipe.transport.interp import blend_gaussians, crossfade, evaluate, interpolate_views
from sgpipe.transport.sampling import light_cube
from sgpipe.transport.views import nearest_views, view_set

VIEWS = view_set()[0]


def queries(n=40, seed=0):
    q = np.random.default_rng(seed).normal(size=(n, 3))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


@pytest.mark.parametrize("kind", ["mirror", "rotation"])
def test_rotated_gaussian_stays_one_gaussian(kind):
    """Means that are a linear map of the view (a mirror reflection about n, a rotation R)
    interpolate to exactly the mapped query view; σ and w are constant, so the interpolated
    lobe is the exact lobe of the query view."""
    n = np.array([0.3, 0.9, -0.2]) / np.linalg.norm([0.3, 0.9, -0.2])
    if kind == "mirror":
        A = 2 * np.outer(n, n) - np.eye(3)
    else:
        A = axis_angle_matrix(np.array([1.0, 2.0, 0.5]), 0.7)
    mu = (VIEWS @ A.T)[:, None, :]
    sigma = np.full((92, 1), 0.08)
    w = np.tile([1.0, 0.7, 0.4], (92, 1, 1))
    cube = light_cube(32)
    q = queries()
    m, s, ww = interpolate_views(mu, sigma, w, q)
    exact = q @ A.T
    assert np.allclose(m[:, 0], exact, atol=1e-12)
    assert np.allclose(s, 0.08) and np.allclose(ww, w[0])
    worst_fade = 0.0
    for i in range(len(q)):
        lobe = evaluate(cube.dirs, m[i], s[i], ww[i])
        ref = evaluate(cube.dirs, exact[i][None], [0.08], w[0])
        assert np.allclose(lobe, ref, atol=1e-10)
        fade = crossfade(cube.dirs, mu, sigma, w, q[i])
        rel = np.sqrt(np.sum((fade - ref) ** 2) / np.sum(ref ** 2))
        worst_fade = max(worst_fade, rel)
        # the cross-fade's peak drops: three half-overlapping lobes instead of one
        assert fade.max() < ref.max() * 0.999 or rel < 1e-6
    assert worst_fade > 0.5     # the linear alternative is far off for such sharp lobes


def test_nearest_views_are_a_partition_of_unity_and_exact_at_the_views():
    q = queries(200, 1)
    idx, b = nearest_views(q)
    assert np.allclose(b.sum(-1), 1) and (b >= 0).all()
    s = np.einsum("nk,nkj->nj", b, VIEWS[idx])
    assert np.allclose(np.cross(s, q), 0, atol=1e-12) and (np.sum(s * q, -1) > 0).all()
    idx, b = nearest_views(VIEWS)
    assert np.array_equal(idx[np.arange(92), np.argmax(b, 1)], np.arange(92))
    assert np.allclose(b.max(1), 1.0)


def test_blend_across_a_triangle_keeps_correspondence():
    mu = np.array([[[1.0, 0, 0], [0, 0, 1.0]], [[0, 1.0, 0], [0, 0, 1.0]],
                   [[1.0, 1.0, 0], [0, 0, 1.0]]])
    mu /= np.linalg.norm(mu, axis=-1, keepdims=True)
    sig = np.array([[0.1, 0.5], [0.2, 0.5], [0.3, 0.5]])
    w = np.ones((3, 2, 3))
    m, s, _ = blend_gaussians(mu, sig, w, np.array([0.5, 0.5, 0.0]))
    assert np.allclose(m[0], np.array([1, 1, 0]) / np.sqrt(2)) and np.allclose(m[1], [0, 0, 1])
    assert np.allclose(s, [0.15, 0.5])


def test_blend_keeps_the_integral_of_narrow_and_broad_lobes():
    """A narrow bright lobe and a broad dim one (grazing vs steeper views): the blended lobe's
    integral over the sphere (quadrature on the light cube) is the blend of their integrals;
    blending w and σ separately would overshoot it by > 30 % half way."""
    cube = light_cube(64)
    n = np.array([0.0, 1.0, 0.0])
    mu = np.tile(n, (3, 1, 1))
    sigma = np.array([[0.05], [0.15], [0.6]])
    w = np.array([[[5.6, 5.0, 4.0]], [[1.1, 1.0, 0.9]], [[0.2, 0.2, 0.1]]])
    integral = [evaluate(cube.dirs, mu[i], sigma[i], w[i]).T @ cube.omega for i in range(3)]
    for b in ([0.5, 0.5, 0.0], [0.2, 0.3, 0.5], [1.0, 0.0, 0.0]):
        m, s, ww = blend_gaussians(mu, sigma, w, np.array(b))
        got = evaluate(cube.dirs, m, s, ww).T @ cube.omega
        want = sum(bi * t for bi, t in zip(b, integral))
        assert np.allclose(got, want, rtol=1e-3), (b, got, want)
    naive = evaluate(cube.dirs, mu[0], [0.1], 0.5 * (w[0] + w[1])).T @ cube.omega
    assert np.all(naive > 1.3 * 0.5 * (integral[0] + integral[1]))
