"""Compact storage round trip: octahedral directions, σ code, half weights, unreachable views
dropped; size well under a third of the paper's 92 × 7 floats."""

import numpy as np

from sgpipe.transport import compact
from sgpipe.transport.views import view_set

VIEWS, _, NB, CNT = view_set()


def test_octahedral_round_trip_is_within_a_hundredth_of_a_degree():
    rng = np.random.default_rng(0)
    d = rng.normal(size=(20000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:6] = np.vstack([np.eye(3), -np.eye(3)])
    back = compact.oct_decode(compact.oct_encode(d))
    ang = np.degrees(np.arccos(np.clip(np.sum(d * back, 1), -1, 1)))
    assert ang.max() < 0.01


def test_round_trip_and_size():
    rng = np.random.default_rng(1)
    X, K = 50, 2
    normals = rng.normal(size=(X, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    active = normals @ VIEWS.T > 0
    mu = rng.normal(size=(X, 92, K, 3))
    mu /= np.linalg.norm(mu, axis=-1, keepdims=True)
    sigma = np.exp(rng.uniform(np.log(0.01), np.log(1.0), size=(X, 92, K)))
    w = rng.uniform(0, 3, size=(X, 92, K, 3)) * active[..., None, None]
    arr = compact.encode(mu, sigma, w, 0.005, 1.5)
    mu2, s2, w2, stored = compact.decode(arr)
    # every weighted view and each of its neighbours is stored: interpolation never misses
    for x in range(X):
        for v in np.flatnonzero(active[x]):
            assert stored[x, v] and stored[x, NB[v, :CNT[v]]].all()
    assert not w2[~active].any()
    assert np.allclose(w2, w, rtol=1e-3, atol=1e-3)
    assert np.max(np.abs(np.log(s2[stored] / sigma[stored]))) <= 0.5 * np.log(300) / 255 + 1e-9
    assert np.sum(mu2[stored] * mu[stored], -1).min() > np.cos(np.radians(0.01))
    ratio = compact.nbytes(arr) / compact.paper_bytes(X, K)
    assert ratio < 1 / 3, ratio
