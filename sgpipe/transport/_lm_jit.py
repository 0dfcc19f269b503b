"""Numba kernels of the Green06 eq 6 objective for one vertex (all 92 views at once):
residuals, analytic Jacobian blocks, the Gauss–Newton matrix-vector product and its PCG solve.

Gaussian (Green06 eq 4, isotropic, peak 1): G(ω; μ, σ) = exp((ω·μ − 1)/σ²) ≈ exp(−θ²/(2σ²)),
so σ is the angular standard deviation (radians); it is the SG of CONVENTIONS with λ = 1/σ².

Parameters per view v and Gaussian k (layout p = 6k + …): a tangent step (δ1, δ2) of the mean
μ_vk on the sphere (μ' = exp_μ(δ1 t1 + δ2 t2), so every step stays a unit vector), s = ln σ, and
the RGB weight w ≥ 0 (a bound: projected LM, below). The objective is a sum of squares
F = ‖r‖² with
  data (eq 7):  r = √(α Ω_j / E_v) (Σ_k w_kc G(ω_j; μ_vk, σ_vk) − T_vjc)  (active views only;
                E_v = Σ_j Ω_j ‖T_vj‖², so each view's term is its relative squared error and the
                BRDF's bright grazing views do not swamp the others)
  means (eq 8): r = √β (μ̄_vk − μ_vk),  μ̄ = mean over the neighbouring views
  sigma (eq 9): r = √γ (σ̄_vk − σ_vk)
  spatial (eq 10): r = √δ max(−d, 0)^{3/2}, d = ⟨μ_vk1 − μ_vk2, ν_k1 − ν_k2⟩ for every
                   processed neighbour vertex's means ν (so r² is eq 10's max(−d, 0)³).
g = Jᵀr and H = JᵀJ (the gradient of F is 2g).

Weights are bounded below by zero (negative weights let a pair of lobes cancel: they fit one
view's samples and interpolate to nonsense between views). The bound is handled by projection
with an active set: a weight at zero whose gradient points below zero is held fixed for that
step (`bound_active`), the others take the LM step and `retract` clips them at zero.
"""

from __future__ import annotations

import numpy as np
from numba import njit

P = 6             # parameters per view per Gaussian
SKIP = 40.0       # (1 − ω·μ)/σ² beyond which G < e^-40 is dropped where T = 0 too


@njit(cache=True)
def tangent_bases(mu):
    """(V, K, 2, 3) orthonormal tangents (t1, t2) at every mean; t1 ⟂ the axis least along μ."""
    V, K = mu.shape[0], mu.shape[1]
    tb = np.empty((V, K, 2, 3))
    for v in range(V):
        for k in range(K):
            m = mu[v, k]
            ax = 0
            if abs(m[1]) < abs(m[ax]):
                ax = 1
            if abs(m[2]) < abs(m[ax]):
                ax = 2
            e = np.zeros(3)
            e[ax] = 1.0
            t1 = np.array([m[1] * e[2] - m[2] * e[1], m[2] * e[0] - m[0] * e[2],
                           m[0] * e[1] - m[1] * e[0]])
            t1 /= np.sqrt(t1 @ t1)
            t2 = np.array([m[1] * t1[2] - m[2] * t1[1], m[2] * t1[0] - m[0] * t1[2],
                           m[0] * t1[1] - m[1] * t1[0]])
            tb[v, k, 0] = t1
            tb[v, k, 1] = t2
    return tb


@njit(cache=True)
def view_data(T, v, dirs, omega, av, mu, s, w, tb, H, g, jac):
    """Σ of the squared data residuals of view v (mu (K, 3), s (K,), w (K, 3), tb (K, 2, 3) of
    that view); with jac, adds their JᵀJ to H (6K, 6K) and Jᵀr to g (6K,). Texel j weighs
    av Ω_j, av = α / E_v.

    The weights enter linearly and w_kc is constant over a view, so JᵀJ factors into sums over
    texels — A_kl = Σ a u_k u_lᵀ, B_kl = Σ a g_l u_k, C_kl = Σ a g_k g_l with
    u_k = ∂G_k/∂(δ1, δ2, s) — and H_{u_k u_l} = (w_k·w_l) A_kl, H_{u_k w_lc} = w_kc B_kl,
    H_{w_kc w_lc} = C_kl: 16 multiply-adds per texel instead of the dense 3·(6K)²/2."""
    M, K = T.shape[1], mu.shape[0]
    F = 0.0
    gk = np.empty(K)
    u = np.empty((K, 3))
    res = np.empty(3)
    A = np.zeros((K, K, 3, 3))
    B = np.zeros((K, K, 3))
    C = np.zeros((K, K))
    inv2 = np.exp(-2.0 * s)          # 1/σ² per Gaussian
    for j in range(M):
        far = True
        for k in range(K):
            c = dirs[j, 0] * mu[k, 0] + dirs[j, 1] * mu[k, 1] + dirs[j, 2] * mu[k, 2]
            x = (c - 1.0) * inv2[k]
            if x > -SKIP:
                far = False
            gk[k] = np.exp(x)
            if jac:
                u[k, 0] = gk[k] * inv2[k] * (dirs[j, 0] * tb[k, 0, 0] + dirs[j, 1] * tb[k, 0, 1]
                                             + dirs[j, 2] * tb[k, 0, 2])
                u[k, 1] = gk[k] * inv2[k] * (dirs[j, 0] * tb[k, 1, 0] + dirs[j, 1] * tb[k, 1, 1]
                                             + dirs[j, 2] * tb[k, 1, 2])
                u[k, 2] = -2.0 * x * gk[k]
        if far and T[v, j, 0] == 0.0 and T[v, j, 1] == 0.0 and T[v, j, 2] == 0.0:
            continue
        aj = av * omega[j]
        for c3 in range(3):
            acc = -T[v, j, c3]
            for k in range(K):
                acc += w[k, c3] * gk[k]
            res[c3] = acc
            F += aj * acc * acc
        if not jac:
            continue
        for k in range(K):
            wr = w[k, 0] * res[0] + w[k, 1] * res[1] + w[k, 2] * res[2]
            for p in range(3):
                g[P * k + p] += aj * u[k, p] * wr
            for c3 in range(3):
                g[P * k + 3 + c3] += aj * gk[k] * res[c3]
            for l in range(K):
                C[k, l] += aj * gk[k] * gk[l]
                for p in range(3):
                    B[k, l, p] += aj * gk[l] * u[k, p]
                    for q in range(3):
                        A[k, l, p, q] += aj * u[k, p] * u[l, q]
    if jac:
        for k in range(K):
            for l in range(K):
                ww = w[k, 0] * w[l, 0] + w[k, 1] * w[l, 1] + w[k, 2] * w[l, 2]
                for p in range(3):
                    for q in range(3):
                        H[P * k + p, P * l + q] += ww * A[k, l, p, q]
                    for c3 in range(3):
                        # H[u_k, w_lc] = Σ a (w_kc u_k) g_l
                        H[P * k + p, P * l + 3 + c3] += w[k, c3] * B[k, l, p]
                        H[P * l + 3 + c3, P * k + p] += w[k, c3] * B[k, l, p]
                for c3 in range(3):
                    H[P * k + 3 + c3, P * l + 3 + c3] += C[k, l]
    return F


@njit(cache=True)
def data_term(T, active, dirs, omega, av, mu, s, w, tb, H, g, jac):
    """Σ over the active views of `view_data` (H (V, 6K, 6K), g (V, 6K))."""
    F = 0.0
    for v in range(T.shape[0]):
        if active[v]:
            F += view_data(T, v, dirs, omega, av[v], mu[v], s[v], w[v], tb[v], H[v], g[v], jac)
    return F


@njit(cache=True)
def bound_active(w, g):
    """(6K,) mask of the parameters held this step: weights at the bound w = 0 whose descent
    direction −g points below it (w (K, 3) and g (6K,) of one view)."""
    K = w.shape[0]
    held = np.zeros(P * K, np.bool_)
    for k in range(K):
        for c in range(3):
            if w[k, c] <= 0.0 and g[P * k + 3 + c] >= 0.0:
                held[P * k + 3 + c] = True
    return held


@njit(cache=True)
def fit_views_independently(T, active, dirs, omega, av, mu, s, w, s_lo, s_hi, max_iter, ftol):
    """Levenberg–Marquardt on each active view's data term alone, with its own damping, in
    place: the start of the joint eq 6 solve (where one global damping would let the slowest
    view hold back the others)."""
    K = mu.shape[1]
    n = P * K
    for v in range(T.shape[0]):
        if not active[v]:
            continue
        lam = 1e-2
        tb = tangent_bases(mu[v:v + 1])
        H = np.zeros((n, n))
        g = np.zeros(n)
        F = view_data(T, v, dirs, omega, av[v], mu[v], s[v], w[v], tb[0], H, g, True)
        for _ in range(max_iter):
            D = np.empty(n)
            dmax = 0.0
            for p in range(n):
                dmax = max(dmax, H[p, p])
            for p in range(n):
                D[p] = max(H[p, p], 1e-9 * max(dmax, 1e-300))
            accepted = False
            F2 = F
            x = np.zeros((1, n))
            held = bound_active(w[v], g)
            while lam < 1e10:
                A = H.copy()
                rhs = -g.copy()
                for p in range(n):
                    A[p, p] += lam * D[p]
                for p in range(n):
                    if held[p]:
                        # the bound holds this weight: decouple it and give it a zero step
                        for q in range(n):
                            A[p, q] = 0.0
                            A[q, p] = 0.0
                        A[p, p] = 1.0
                        rhs[p] = 0.0
                x[0] = np.linalg.solve(A, rhs)
                mu2, s2, w2 = retract(mu[v:v + 1], s[v:v + 1], w[v:v + 1], tb, x, s_lo, s_hi)
                F2 = view_data(T, v, dirs, omega, av[v], mu2[0], s2[0], w2[0], tb[0], H, g,
                               False)
                if F2 < F:
                    accepted = True
                    break
                lam *= 4.0
            if not accepted:
                break
            done = F - F2 <= ftol * F
            mu[v], s[v], w[v] = mu2[0], s2[0], w2[0]
            lam = max(lam / 3.0, 1e-9)
            tb = tangent_bases(mu[v:v + 1])
            H[:] = 0.0
            g[:] = 0.0
            F = view_data(T, v, dirs, omega, av[v], mu[v], s[v], w[v], tb[0], H, g, True)
            if done:
                break


@njit(cache=True)
def coherence_term(mu, s, nb, cnt, tb, beta, gamma, g, jac):
    """Σ of the squared mean (eq 8) and σ (eq 9) coherence residuals over all views; with jac,
    adds Jᵀr to g. (Their JᵀJ is applied matrix-free by `apply_h`.)"""
    V, K = mu.shape[0], mu.shape[1]
    F = 0.0
    for v in range(V):
        R = cnt[v]
        for k in range(K):
            m = -mu[v, k].copy()
            z = -np.exp(s[v, k])
            for i in range(R):
                u = nb[v, i]
                m += mu[u, k] / R
                z += np.exp(s[u, k]) / R
            F += beta * (m @ m) + gamma * z * z
            if not jac:
                continue
            for a2 in range(2):
                g[v, P * k + a2] -= beta * (tb[v, k, a2] @ m)
            g[v, P * k + 2] -= gamma * np.exp(s[v, k]) * z
            for i in range(R):
                u = nb[v, i]
                for a2 in range(2):
                    g[u, P * k + a2] += beta / R * (tb[u, k, a2] @ m)
                g[u, P * k + 2] += gamma / R * np.exp(s[u, k]) * z
    return F


@njit(cache=True)
def spatial_term(mu, tb, nbmu, delta, H, g, jac):
    """Σ of eq 10's max(−d, 0)³ over views, Gaussian pairs k1 < k2 and processed neighbour
    vertices (nbmu (S, V, K, 3)); with jac adds the JᵀJ blocks and Jᵀr."""
    V, K, S = mu.shape[0], mu.shape[1], nbmu.shape[0]
    F = 0.0
    if K < 2 or delta == 0.0:
        return F
    sd = np.sqrt(delta)
    for v in range(V):
        for k1 in range(K - 1):
            for k2 in range(k1 + 1, K):
                for n in range(S):
                    e = nbmu[n, v, k1] - nbmu[n, v, k2]
                    d = (mu[v, k1] - mu[v, k2]) @ e
                    if d >= 0.0:
                        continue
                    r = sd * (-d) ** 1.5
                    F += r * r
                    if not jac:
                        continue
                    dr = -1.5 * sd * np.sqrt(-d)          # ∂r/∂d
                    Jr = np.zeros(P * K)
                    for a2 in range(2):
                        Jr[P * k1 + a2] = dr * (tb[v, k1, a2] @ e)
                        Jr[P * k2 + a2] = -dr * (tb[v, k2, a2] @ e)
                    for p in range(P * K):
                        if Jr[p] == 0.0:
                            continue
                        g[v, p] += Jr[p] * r
                        for q in range(P * K):
                            H[v, p, q] += Jr[p] * Jr[q]
    return F


@njit(cache=True)
def apply_h(x, Hd, nb, cnt, tb, sig, beta, gamma, lam, D, free, out):
    """out = (JᵀJ + λ diag(D)) x for the data/spatial blocks Hd plus the coherence terms."""
    V, n = x.shape[0], x.shape[1]
    K = n // P
    for v in range(V):
        for p in range(n):
            acc = lam * D[v, p] * x[v, p]
            for q in range(n):
                acc += Hd[v, p, q] * x[v, q]
            out[v, p] = acc
    for v in range(V):
        R = cnt[v]
        for k in range(K):
            y = -(x[v, P * k] * tb[v, k, 0] + x[v, P * k + 1] * tb[v, k, 1])
            z = -sig[v, k] * x[v, P * k + 2]
            for i in range(R):
                u = nb[v, i]
                y += (x[u, P * k] * tb[u, k, 0] + x[u, P * k + 1] * tb[u, k, 1]) / R
                z += sig[u, k] * x[u, P * k + 2] / R
            for a2 in range(2):
                out[v, P * k + a2] -= beta * (tb[v, k, a2] @ y)
            out[v, P * k + 2] -= gamma * sig[v, k] * z
            for i in range(R):
                u = nb[v, i]
                for a2 in range(2):
                    out[u, P * k + a2] += beta / R * (tb[u, k, a2] @ y)
                out[u, P * k + 2] += gamma / R * sig[u, k] * z
    for v in range(V):
        for p in range(n):
            if not free[v, p]:
                out[v, p] = 0.0


@njit(cache=True)
def self_diagonal(nb, cnt, sig, beta, gamma, K):
    """(V, 6K) diagonal of the coherence terms' JᵀJ (tangent bases are orthonormal)."""
    V = nb.shape[0]
    sw = np.ones(V)
    for v in range(V):
        for i in range(cnt[v]):
            sw[nb[v, i]] += 1.0 / (cnt[v] * cnt[v])
    out = np.zeros((V, P * K))
    for v in range(V):
        for k in range(K):
            out[v, P * k] = beta * sw[v]
            out[v, P * k + 1] = beta * sw[v]
            out[v, P * k + 2] = gamma * sig[v, k] ** 2 * sw[v]
    return out


@njit(cache=True)
def solve_step(Hd, g, nb, cnt, tb, sig, beta, gamma, lam, D, selfd, free, maxit, rtol):
    """Δ solving (JᵀJ + λ diag D) Δ = −g by conjugate gradients, preconditioned with the
    inverse of every view's diagonal block (Hd + coherence diagonal + λD)."""
    V, n = g.shape[0], g.shape[1]
    Pinv = np.zeros((V, n, n))
    for v in range(V):
        B = Hd[v].copy()
        for p in range(n):
            B[p, p] += selfd[v, p] + lam * D[v, p]
        for p in range(n):
            if not free[v, p]:
                for q in range(n):
                    B[p, q] = 0.0
                    B[q, p] = 0.0
                B[p, p] = 1.0
        Pinv[v] = np.linalg.inv(B)
    x = np.zeros((V, n))
    r = -g.copy()
    for v in range(V):
        for p in range(n):
            if not free[v, p]:
                r[v, p] = 0.0
    z = np.empty((V, n))
    for v in range(V):
        z[v] = Pinv[v] @ r[v]
    d = z.copy()
    rz = np.sum(r * z)
    r0 = np.sqrt(np.sum(r * r))
    Ad = np.empty((V, n))
    for _ in range(maxit):
        if np.sqrt(np.sum(r * r)) <= rtol * r0 or r0 == 0.0:
            break
        apply_h(d, Hd, nb, cnt, tb, sig, beta, gamma, lam, D, free, Ad)
        dAd = np.sum(d * Ad)
        if dAd <= 0.0:
            break
        al = rz / dAd
        x += al * d
        r -= al * Ad
        for v in range(V):
            z[v] = Pinv[v] @ r[v]
        rz_new = np.sum(r * z)
        d = z + (rz_new / rz) * d
        rz = rz_new
    return x


@njit(cache=True)
def retract(mu, s, w, tb, x, s_lo, s_hi):
    """The candidate parameters after step x: means moved along the sphere's geodesics, ln σ
    clipped to [s_lo, s_hi], weights projected onto w ≥ 0."""
    V, K = mu.shape[0], mu.shape[1]
    mu2 = np.empty_like(mu)
    s2 = np.empty_like(s)
    w2 = np.empty_like(w)
    for v in range(V):
        for k in range(K):
            d = x[v, P * k] * tb[v, k, 0] + x[v, P * k + 1] * tb[v, k, 1]
            th = np.sqrt(d @ d)
            if th > 1e-300:
                m = np.cos(th) * mu[v, k] + np.sin(th) / th * d
            else:
                m = mu[v, k].copy()
            mu2[v, k] = m / np.sqrt(m @ m)
            s2[v, k] = min(max(s[v, k] + x[v, P * k + 2], s_lo), s_hi)
            for c in range(3):
                w2[v, k, c] = max(w[v, k, c] + x[v, P * k + 3 + c], 0.0)
    return mu2, s2, w2
