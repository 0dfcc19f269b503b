"""SSDF (Wang09 eq 23): exact search vs brute force, vs literal eq 23, vs closed forms."""

import numpy as np
import pytest

from sgpipe.visibility.hemigrid import max_texel_spacing, texel_dirs, texel_spacing
from sgpipe.visibility.ssdf import (downsample_visibility, ssdf_bruteforce, ssdf_eq23_samples,
                                    ssdf_from_visibility)


def random_caps_visibility(trace, rng, n_caps=5):
    d = texel_dirs(trace)
    vis = np.ones((trace, trace), bool)
    for _ in range(n_caps):
        c = rng.normal(size=3)
        c /= np.linalg.norm(c)
        vis &= ~(d @ c > np.cos(rng.uniform(0.05, 0.9)))
    return vis


@pytest.mark.parametrize("trace,res", [(64, 16), (96, 24), (128, 32), (128, 8)])
def test_exact_search_equals_bruteforce(trace, res):
    rng = np.random.default_rng(trace + res)
    for _ in range(4):
        vis = random_caps_visibility(trace, rng)
        fast = ssdf_from_visibility(vis, res)
        slow = ssdf_bruteforce(vis, res)
        np.testing.assert_allclose(fast, slow, atol=2e-6)


def test_noise_visibility_equals_bruteforce():
    # thousands of tiny boundary pieces: the branch and bound must still be exact
    rng = np.random.default_rng(3)
    vis = rng.random((64, 64)) > 0.3
    np.testing.assert_allclose(ssdf_from_visibility(vis, 16), ssdf_bruteforce(vis, 16),
                               atol=2e-6)


def test_sign_and_distance_vs_literal_eq23():
    """Boundary midpoints vs nearest opposite-class sample: within one trace-texel spacing."""
    rng = np.random.default_rng(7)
    trace, res = 64, 16
    h = max_texel_spacing(trace)
    for _ in range(3):
        vis = random_caps_visibility(trace, rng)
        a = ssdf_from_visibility(vis, res)
        b = ssdf_eq23_samples(vis, res)
        assert np.max(np.abs(a - b)) <= h
        far = np.abs(b) > 2 * texel_spacing(res)
        assert np.array_equal(np.sign(a[far]), np.sign(b[far]))


def test_fully_visible_and_fully_occluded_are_clamped():
    res, trace = 16, 64
    q = texel_dirs(res)
    s = ssdf_from_visibility(np.ones((trace, trace), bool), res, max_distance=np.pi / 2)
    np.testing.assert_allclose(s, np.arcsin(q[..., 2]), atol=1e-6)   # horizon = boundary
    s = ssdf_from_visibility(np.zeros((trace, trace), bool), res, max_distance=1.2)
    assert np.all(s == np.float32(-1.2))
    s = ssdf_from_visibility(np.ones((trace, trace), bool), res, max_distance=0.3)
    assert s.max() == np.float32(0.3) and s.min() > 0


@pytest.mark.parametrize("normal", [(1.0, 0.0, 0.0), (0.6, 0.0, 0.8), (0.3, -0.5, 0.81)])
def test_great_circle_boundary_closed_form(normal):
    """Visibility = {ℓ·m > 0} (hemisphere cut by a great circle): S = min(asin(ℓ·m), asin(ℓ_z))
    where visible and asin(ℓ·m) where occluded (exact angles on the sphere)."""
    m = np.asarray(normal) / np.linalg.norm(normal)
    trace, res = 128, 32
    vis = texel_dirs(trace) @ m > 0
    q = texel_dirs(res)
    qm = q @ m
    proj_z = q[..., 2] - qm * m[2]
    # distance to the boundary arc {ℓ·m = 0, ℓ_z ≥ 0}: its foot point, else an arc end
    ends = np.cross(m, [0.0, 0.0, 1.0])
    ends /= np.linalg.norm(ends)
    end_d = np.minimum(np.arccos(np.clip(q @ ends, -1, 1)), np.arccos(np.clip(-q @ ends, -1, 1)))
    arc = np.where(proj_z >= 0, np.arcsin(np.abs(qm)), end_d)
    truth = np.where(qm > 0, np.minimum(arc, np.arcsin(q[..., 2])), -arc)
    s = ssdf_from_visibility(vis, res, max_distance=np.pi)
    assert np.max(np.abs(s - truth)) <= max_texel_spacing(trace)
    far = np.abs(truth) > texel_spacing(res)
    assert np.array_equal(s[far] > 0, truth[far] > 0)


def test_downsample_is_block_mean():
    rng = np.random.default_rng(0)
    vis = rng.random((32, 32)) > 0.5
    f = downsample_visibility(vis, 8)
    np.testing.assert_allclose(f[2, 5], vis[8:12, 20:24].mean())
    with pytest.raises(ValueError):
        downsample_visibility(vis, 7)
