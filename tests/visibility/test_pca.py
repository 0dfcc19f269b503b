"""Streaming randomized PCA of SSDF rows (Wang09 eq 24) against exact SVD."""

import numpy as np
import pytest

from sgpipe.visibility.pca import streaming_pca


def low_rank(rng, n=200, d=96, rank=12, noise=1e-3):
    u = rng.normal(size=(n, rank))
    v = np.linalg.qr(rng.normal(size=(d, rank)))[0].T
    s = 2.0 ** -np.arange(rank)
    return (u * s) @ v + 0.3 + noise * rng.normal(size=(n, d))


def test_all_terms_reproduce_the_input():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(30, 64))
    p = streaming_pca(X, 64, block=7)
    assert p.basis.shape == (30, 64)
    np.testing.assert_allclose(p.reconstruct(), X, atol=1e-9)
    np.testing.assert_allclose(p.basis @ p.basis.T, np.eye(30), atol=1e-10)
    assert p.residual_energy[-1] < 1e-9 * p.residual_energy[0]


def test_matches_exact_svd_and_residuals_are_exact():
    rng = np.random.default_rng(1)
    X = low_rank(rng)
    k = 8
    p = streaming_pca(X, k, power_iterations=3, block=33)
    Xc = X - X.mean(0)
    _, s, vt = np.linalg.svd(Xc, full_matrices=False)
    np.testing.assert_allclose(p.explained_variance, s[:k] ** 2 / len(X), rtol=1e-6)
    # same subspace: |cos| of principal angles = 1
    c = np.abs(np.sum(p.basis * vt[:k], axis=1))
    np.testing.assert_allclose(c, 1.0, atol=1e-6)
    for m in (0, 3, k):
        direct = np.sum((X - p.reconstruct(terms=m)) ** 2)
        np.testing.assert_allclose(p.residual_energy[m], direct, rtol=1e-8, atol=1e-12)


def test_memmap_input_is_identical_and_deterministic(tmp_path):
    rng = np.random.default_rng(2)
    X = low_rank(rng, n=150, d=64).astype(np.float32)
    mm = np.memmap(tmp_path / "x.f32", np.float32, "w+", shape=X.shape)
    mm[:] = X
    mm.flush()
    a = streaming_pca(X, 6, seed=4, block=1000)
    b = streaming_pca(np.memmap(tmp_path / "x.f32", np.float32, "r", shape=X.shape), 6,
                      seed=4, block=1000)
    assert np.array_equal(a.basis, b.basis) and np.array_equal(a.coeffs, b.coeffs)


@pytest.mark.parametrize("k", [1, 5])
def test_terms_clip_to_rank_limits(k):
    X = np.random.default_rng(3).normal(size=(4, 10))
    p = streaming_pca(X, k)
    assert p.basis.shape[0] == min(k, 4)
