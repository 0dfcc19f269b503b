"""Compiled core of spherical EM (Han07 Algorithm 1, weighted samples, eq 22–23)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

_LOG_4PI = math.log(4.0 * math.pi)
_LOG_2PI = math.log(2.0 * math.pi)


@njit(cache=True)
def log_vmf_norm(kappa):
    """log of κ/(2π(1 − e^{−2κ})), so that vMF(x) = exp(lognorm + κ(μ·x − 1))."""
    if kappa < 1e-8:
        return -_LOG_4PI
    return math.log(kappa) - _LOG_2PI - math.log(-math.expm1(-2.0 * kappa))


@njit(cache=True)
def kappa_banerjee(rbar):
    """Banerjee et al. 2005 approximation of A⁻¹(r̄) on S²: κ = r̄(3 − r̄²)/(1 − r̄²)."""
    r = min(max(rbar, 0.0), 1.0 - 1e-12)
    return r * (3.0 - r * r) / (1.0 - r * r)


@njit(cache=True)
def em_vmf(x, w, y, alpha, mu, kappa, nb_alpha, nb_mu, c_align, max_iter, tol, kappa_max,
           y_out):
    """Weighted spherical EM in place on (alpha (K,), mu (K,3), kappa (K,)).

    x (M,3) unit samples, w (M,) weights >= 0, y (M,F) feature vectors (Han07 eq 22, result in
    y_out (K,F)), nb_alpha (N,K) / nb_mu (N,K,3): neighbour lobes pulling μ_k with strength
    c_align/κ_k (Han07 eq 23 with the appendix's C = C'/κ_j).
    Returns (mean log-likelihood per unit weight, iterations run)."""
    m = x.shape[0]
    k_n = alpha.shape[0]
    f_n = y.shape[1]
    n_nb = nb_alpha.shape[0]
    wsum = 0.0
    for s in range(m):
        wsum += w[s]
    if wsum <= 0.0:
        return 0.0, 0
    lnorm = np.empty(k_n)
    logit = np.empty(k_n)
    ssum = np.empty(k_n)
    rsum = np.empty((k_n, 3))
    ysum = np.empty((k_n, f_n))
    prev = -np.inf
    ll = 0.0
    it = 0
    for it in range(max_iter):
        for k in range(k_n):
            if alpha[k] > 0.0:
                lnorm[k] = math.log(alpha[k]) + log_vmf_norm(kappa[k]) - kappa[k]
            else:
                lnorm[k] = -np.inf
        ssum[:] = 0.0
        rsum[:, :] = 0.0
        ysum[:, :] = 0.0
        ll = 0.0
        for s in range(m):                      # E-step fused with the M-step sums
            ws = w[s]
            if ws <= 0.0:
                continue
            x0 = x[s, 0]
            x1 = x[s, 1]
            x2 = x[s, 2]
            big = -np.inf
            for k in range(k_n):
                v = lnorm[k] + kappa[k] * (mu[k, 0] * x0 + mu[k, 1] * x1 + mu[k, 2] * x2)
                logit[k] = v
                if v > big:
                    big = v
            if big == -np.inf:
                continue
            tot = 0.0
            for k in range(k_n):
                e = math.exp(logit[k] - big)
                logit[k] = e
                tot += e
            ll += ws * (big + math.log(tot))
            inv = ws / tot
            for k in range(k_n):
                z = logit[k] * inv
                ssum[k] += z
                rsum[k, 0] += z * x0
                rsum[k, 1] += z * x1
                rsum[k, 2] += z * x2
                for f in range(f_n):
                    ysum[k, f] += z * y[s, f]
        ll /= wsum
        for k in range(k_n):                    # M-step (Algorithm 1 lines 9-14)
            if ssum[k] <= 1e-12 * wsum:
                alpha[k] = 0.0
                continue
            alpha[k] = ssum[k] / wsum
            r0 = rsum[k, 0] / ssum[k]
            r1 = rsum[k, 1] / ssum[k]
            r2 = rsum[k, 2] / ssum[k]
            rbar = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            kappa[k] = min(kappa_banerjee(rbar), kappa_max)
            pull = c_align / max(kappa[k], 1e-6)   # Han07 appendix: C = C'/κ_j
            for n in range(n_nb):               # Han07 eq 23 alignment prior
                r0 += pull * nb_alpha[n, k] * nb_mu[n, k, 0]
                r1 += pull * nb_alpha[n, k] * nb_mu[n, k, 1]
                r2 += pull * nb_alpha[n, k] * nb_mu[n, k, 2]
            nr = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            if nr > 0.0:
                mu[k, 0] = r0 / nr
                mu[k, 1] = r1 / nr
                mu[k, 2] = r2 / nr
            for f in range(f_n):
                y_out[k, f] = ysum[k, f] / ssum[k]
        if abs(ll - prev) <= tol * max(1.0, abs(ll)):
            break
        prev = ll
    return ll, it + 1


@njit(cache=True)
def _set_moments(x, w, sel, k, alpha, mu, kappa, kappa_max):
    """alpha_k = Σw, mu_k = mean direction, kappa_k = Banerjee(‖mean‖) of samples `sel`."""
    sw = 0.0
    r0 = r1 = r2 = 0.0
    for s in sel:
        sw += w[s]
        r0 += w[s] * x[s, 0]
        r1 += w[s] * x[s, 1]
        r2 += w[s] * x[s, 2]
    if sw <= 0.0:
        return 0.0
    r0 /= sw
    r1 /= sw
    r2 /= sw
    rb = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    if rb > 0.0:
        mu[k, 0] = r0 / rb
        mu[k, 1] = r1 / rb
        mu[k, 2] = r2 / rb
    kappa[k] = min(kappa_banerjee(rb), kappa_max)
    alpha[k] = sw
    return sw


@njit(cache=True)
def init_sort_split(x, w, alpha, mu, kappa, kappa_max):
    """Töral19 §IV initialisation in place: spherical coordinates (θ, φ) of the samples about
    their mean direction m (tangent x-axis projected, else y), sort along the highest-variance
    axis of (θ cos φ, θ sin φ), split into K sets of equal weight, moments of each set."""
    k_n = alpha.shape[0]
    idx = np.nonzero(w > 0.0)[0]
    for k in range(k_n):
        alpha[k] = 1.0 / k_n
        mu[k, 0] = 0.0
        mu[k, 1] = 0.0
        mu[k, 2] = 1.0
        kappa[k] = 1.0
    if idx.size == 0:
        return
    m = np.zeros(3)
    tot = _set_moments(x, w, idx, 0, alpha, mu, kappa, kappa_max)
    m[:] = mu[0]
    hint = np.array([1.0, 0.0, 0.0]) if abs(m[0]) < 0.999 else np.array([0.0, 1.0, 0.0])
    t = hint - np.dot(hint, m) * m
    t /= np.linalg.norm(t)
    b = np.cross(m, t)
    n = idx.size
    p = np.empty((n, 2))
    mean0 = mean1 = 0.0
    for q in range(n):
        s = idx[q]
        xt = x[s, 0] * t[0] + x[s, 1] * t[1] + x[s, 2] * t[2]
        xb = x[s, 0] * b[0] + x[s, 1] * b[1] + x[s, 2] * b[2]
        xm = x[s, 0] * m[0] + x[s, 1] * m[1] + x[s, 2] * m[2]
        th = math.acos(min(1.0, max(-1.0, xm)))
        ph = math.atan2(xb, xt)
        p[q, 0] = th * math.cos(ph)
        p[q, 1] = th * math.sin(ph)
        mean0 += w[s] * p[q, 0]
        mean1 += w[s] * p[q, 1]
    mean0 /= tot
    mean1 /= tot
    c00 = c01 = c11 = 0.0
    for q in range(n):
        d0 = p[q, 0] - mean0
        d1 = p[q, 1] - mean1
        ws = w[idx[q]]
        c00 += ws * d0 * d0
        c01 += ws * d0 * d1
        c11 += ws * d1 * d1
    # principal axis of the 2x2 covariance (closed form)
    ang = 0.5 * math.atan2(2.0 * c01, c00 - c11)
    a0, a1 = math.cos(ang), math.sin(ang)
    proj = np.empty(n)
    for q in range(n):
        proj[q] = (p[q, 0] - mean0) * a0 + (p[q, 1] - mean1) * a1
    order = idx[np.argsort(proj, kind="mergesort")]
    group = np.empty(n, np.int64)
    cw = 0.0
    for q in range(n):
        cw += w[order[q]]
        group[q] = min(int(cw / tot * k_n - 1e-12), k_n - 1)
    for k in range(k_n):
        sel = order[group == k]
        if sel.size == 0 or _set_moments(x, w, sel, k, alpha, mu, kappa, kappa_max) <= 0.0:
            alpha[k] = 1e-6 * tot
            mu[k, :] = m
            kappa[k] = 1.0
    sa = alpha.sum()
    for k in range(k_n):
        alpha[k] /= sa


@njit(cache=True, parallel=True)
def em_vmf_batch(x, w, y, alpha, mu, kappa, max_iter, tol, kappa_max, y_out, ll_out, it_out,
                 do_init):
    """Independent fits of J problems in parallel: x (J,M,3), w (J,M), y (J,M,F), params
    (J,K[,3]) (initialised by `init_sort_split` when do_init), lobe features y_out (J,K,F)."""
    n_j = x.shape[0]
    k_n = alpha.shape[1]
    for j in prange(n_j):
        if do_init:
            init_sort_split(x[j], w[j], alpha[j], mu[j], kappa[j], kappa_max)
        nb_a = np.zeros((0, k_n))
        nb_m = np.zeros((0, k_n, 3))
        ll, it = em_vmf(x[j], w[j], y[j], alpha[j], mu[j], kappa[j], nb_a, nb_m, 0.0, max_iter,
                        tol, kappa_max, y_out[j])
        ll_out[j] = ll
        it_out[j] = it
