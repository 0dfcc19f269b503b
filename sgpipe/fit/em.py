"""Spherical EM for mixtures of vMF lobes (Han07 Algorithm 1 with weighted samples, eq 22–23)
and the sort-and-split initialisation of Töral19 §IV."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sgpipe.core.vmf import vmf_pdf
from sgpipe.fit._em_jit import em_vmf, em_vmf_batch
from sgpipe.fit._em_jit import init_sort_split as _init_jit

KAPPA_MAX = 1e5


@dataclass
class VMFMixture:
    """Σ_k alpha_k vMF(x; mu_k, kappa_k); alpha sums to 1 for an EM fit (a density)."""

    alpha: np.ndarray   # (..., K)
    mu: np.ndarray      # (..., K, 3)
    kappa: np.ndarray   # (..., K)
    loglik: float | np.ndarray = 0.0
    iterations: int | np.ndarray = 0
    features: np.ndarray | None = None   # (K, F) Han07 eq 22

    def eval(self, x):
        """Mixture density at directions x (N, 3) -> (N,) (single mixture)."""
        x = np.asarray(x, float)
        return np.sum(self.alpha * vmf_pdf(x[:, None, :], self.mu, self.kappa), axis=-1)


def init_sort_split(x, w, n_lobes: int, kappa_max: float = KAPPA_MAX):
    """Töral19 §IV initialisation: spherical coordinates (θ, φ) of the samples about their
    mean direction, sort along the highest-variance axis of (θ cos φ, θ sin φ), split into
    n_lobes sets of equal weight, moments of each set -> (alpha (K,), mu (K,3), kappa (K,))."""
    alpha = np.empty(n_lobes)
    mu = np.empty((n_lobes, 3))
    kappa = np.empty(n_lobes)
    _init_jit(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(w, dtype=float),
              alpha, mu, kappa, float(kappa_max))
    return alpha, mu, kappa


def spherical_em(x, weights=None, n_lobes: int = 8, *, init=None, features=None,
                 neighbors=None, align: float = 0.0, max_iter: int = 100, tol: float = 1e-6,
                 kappa_max: float = KAPPA_MAX) -> VMFMixture:
    """Fit a vMF mixture to unit samples x (M,3) with optional weights (M,) (Han07 Alg. 1).

    init: None (sort-and-split) or (alpha, mu, kappa). features (M,F): per-sample vectors whose
    lobe means are returned (Han07 eq 22). neighbors: list of (alpha (K,), mu (K,3)) of
    neighbouring fits; `align` = C of Han07 eq 23 pulls mu_k towards them."""
    x = np.ascontiguousarray(x, dtype=float)
    w = np.ones(x.shape[0]) if weights is None else np.ascontiguousarray(weights, dtype=float)
    if init is None:
        alpha, mu, kappa = init_sort_split(x, w, n_lobes)
    else:
        alpha, mu, kappa = (np.array(a, dtype=float) for a in init)
    k = alpha.shape[0]
    y = np.zeros((x.shape[0], 0)) if features is None else np.ascontiguousarray(features, float)
    y_out = np.zeros((k, y.shape[1]))
    if neighbors:
        nb_a = np.ascontiguousarray([n[0] for n in neighbors], dtype=float)
        nb_m = np.ascontiguousarray([n[1] for n in neighbors], dtype=float)
    else:
        nb_a, nb_m = np.zeros((0, k)), np.zeros((0, k, 3))
    alpha, mu, kappa = (np.ascontiguousarray(a) for a in (alpha, mu, kappa))
    ll, it = em_vmf(x, w, y, alpha, mu, kappa, nb_a, nb_m, float(align), int(max_iter),
                    float(tol), float(kappa_max), y_out)
    return VMFMixture(alpha, mu, kappa, float(ll), int(it),
                      None if features is None else y_out)


def spherical_em_batch(x, weights, n_lobes: int = 8, *, features=None, max_iter: int = 100,
                       tol: float = 1e-6, kappa_max: float = KAPPA_MAX) -> VMFMixture:
    """Independent fits of J sample sets x (J,M,3), weights (J,M) [, features (J,M,F)] in
    parallel threads (numba prange); each starts from `init_sort_split`."""
    x = np.ascontiguousarray(x, dtype=float)
    w = np.ascontiguousarray(weights, dtype=float)
    n_j = x.shape[0]
    y = (np.zeros(x.shape[:2] + (0,)) if features is None
         else np.ascontiguousarray(features, dtype=float))
    y_out = np.zeros((n_j, n_lobes, y.shape[2]))
    alpha = np.empty((n_j, n_lobes))
    mu = np.empty((n_j, n_lobes, 3))
    kappa = np.empty((n_j, n_lobes))
    ll = np.zeros(n_j)
    it = np.zeros(n_j, dtype=np.int64)
    # one numba call per group of `threads` views: a signal is handled between calls, so
    # Ctrl-C ends a long fit within one group's time instead of the whole batch's
    import numba
    step = max(1, numba.get_num_threads())
    for s in range(0, n_j, step):
        e = min(s + step, n_j)
        em_vmf_batch(x[s:e], w[s:e], y[s:e], alpha[s:e], mu[s:e], kappa[s:e], int(max_iter),
                     float(tol), float(kappa_max), y_out[s:e], ll[s:e], it[s:e], True)
    return VMFMixture(alpha, mu, kappa, ll, it, None if features is None else y_out)
