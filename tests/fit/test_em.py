"""Spherical EM (Han07 Algorithm 1): parameter recovery, weights, features, alignment prior."""

from __future__ import annotations

import numpy as np
import pytest

from sgpipe.core.sphere import tangent_frame
from sgpipe.core.vmf import kappa_from_rbar
from sgpipe.fit._em_jit import kappa_banerjee, log_vmf_norm
from sgpipe.fit.em import init_sort_split, spherical_em, spherical_em_batch


def sample_vmf(rng, mu, kappa, n):
    """Wood (1994) exact vMF sampler on S²."""
    u = rng.random(n)
    w = 1.0 + np.log(u + (1.0 - u) * np.exp(-2.0 * kappa)) / kappa
    phi = 2 * np.pi * rng.random(n)
    s = np.sqrt(np.maximum(0.0, 1 - w * w))
    t, b = tangent_frame(mu)
    return (s * np.cos(phi))[:, None] * t + (s * np.sin(phi))[:, None] * b + w[:, None] * mu


MUS = np.array([[0, 0, 1.0], [1, 0, 0.3], [0, -1, 0.6]])
MUS /= np.linalg.norm(MUS, axis=1, keepdims=True)
KAPPAS = np.array([60.0, 15.0, 250.0])
ALPHAS = np.array([0.5, 0.3, 0.2])


def _mixture_samples(n, seed=0):
    rng = np.random.default_rng(seed)
    counts = rng.multinomial(n, ALPHAS)
    x = np.concatenate([sample_vmf(rng, MUS[k], KAPPAS[k], counts[k]) for k in range(3)])
    labels = np.repeat(np.arange(3), counts)
    return x, labels


def _match(mix):
    """Fitted lobe index for each true lobe (nearest axis)."""
    return [int(np.argmax(mix.mu @ m)) for m in MUS]


def test_recovers_known_mixture():
    x, _ = _mixture_samples(30000)
    mix = spherical_em(x, n_lobes=3, max_iter=300, tol=1e-9)
    idx = _match(mix)
    assert sorted(idx) == [0, 1, 2]
    np.testing.assert_allclose(mix.alpha[idx], ALPHAS, atol=0.01)
    np.testing.assert_allclose(mix.kappa[idx], KAPPAS, rtol=0.06)
    assert np.min(np.sum(mix.mu[idx] * MUS, 1)) > np.cos(np.radians(1.0))


def test_weights_equal_duplicated_samples():
    x, _ = _mixture_samples(3000, seed=2)
    w = np.where(np.arange(len(x)) % 3 == 0, 2.0, 1.0)
    dup = np.concatenate([x, x[w == 2.0]])
    init = init_sort_split(dup, np.ones(len(dup)), 3)
    a = spherical_em(x, w, 3, init=init, max_iter=50, tol=0)
    b = spherical_em(dup, None, 3, init=init, max_iter=50, tol=0)
    np.testing.assert_allclose(a.alpha, b.alpha, rtol=1e-9)
    np.testing.assert_allclose(a.kappa, b.kappa, rtol=1e-9)


def test_banerjee_kappa_and_normaliser_match_core():
    r = np.linspace(0.0, 0.999, 50)
    np.testing.assert_allclose([kappa_banerjee(v) for v in r], kappa_from_rbar(r), rtol=1e-12)
    for k in (1e-9, 0.5, 20.0, 3000.0):
        ref = np.log(k / (4 * np.pi * np.sinh(k)) * np.exp(k)) if k < 500 else \
            np.log(k / (2 * np.pi))
        assert log_vmf_norm(k) == pytest.approx(ref, rel=1e-9, abs=1e-9)   # κe^κ/(4π sinh κ)


def test_feature_vectors_eq22():
    x, labels = _mixture_samples(20000, seed=3)
    colours = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    mix = spherical_em(x, n_lobes=3, features=colours[labels], max_iter=200)
    idx = _match(mix)
    np.testing.assert_allclose(mix.features[idx], colours, atol=0.03)


def test_alignment_prior_pulls_axes_eq23():
    x, _ = _mixture_samples(5000, seed=4)
    init = init_sort_split(x, np.ones(len(x)), 3)
    free = spherical_em(x, n_lobes=3, init=init, max_iter=30, tol=0)
    target = np.tile([1.0, 0.0, 0.0], (3, 1))
    pulled = spherical_em(x, n_lobes=3, init=init, max_iter=30, tol=0,
                          neighbors=[(np.ones(3), target)], align=1e4)
    assert np.all(pulled.mu @ [1.0, 0, 0] > free.mu @ [1.0, 0, 0] - 1e-12)
    assert np.mean(pulled.mu @ [1.0, 0, 0]) > np.mean(free.mu @ [1.0, 0, 0]) + 0.05


def test_batch_equals_single_fits():
    xs = np.stack([_mixture_samples(2048, seed=s)[0] for s in range(3)])
    w = np.ones(xs.shape[:2])
    batch = spherical_em_batch(xs, w, 4, max_iter=40)
    for j in range(3):
        one = spherical_em(xs[j], w[j], 4, max_iter=40)
        np.testing.assert_allclose(batch.alpha[j], one.alpha, rtol=1e-12)
        np.testing.assert_allclose(batch.mu[j], one.mu, rtol=1e-12)


def test_sort_split_init_moments():
    """Töral19 init: equal-weight sets; each lobe's κ is its set's Banerjee moment estimate."""
    x, _ = _mixture_samples(4000, seed=5)
    a, mu, k = init_sort_split(x, np.ones(len(x)), 8)
    np.testing.assert_allclose(a, 1 / 8, atol=1e-3)
    np.testing.assert_allclose(np.linalg.norm(mu, axis=1), 1.0)
    assert np.all(k > 0)
