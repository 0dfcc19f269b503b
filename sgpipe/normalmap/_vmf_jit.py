"""Compiled core of the vMF pyramid (Han07 §7.1 and §7.3): per-texel spherical EM over the
normals a texel covers (Algorithm 1 via sgpipe.fit._em_jit.em_vmf), Hochbaum–Shmoys
initialisation from the four finer texels (pass 1, fine → coarse), and the aligned pass 2
(coarse → fine, eq 23): lobe slots matched in scan-line order, then EM with the alignment pull
for all texels at once.

Lobe parameters of a level: alpha (m, m, J), mu (m, m, J, 3), kappa (m, m, J) and rbar
(m, m, J), the mean resultant length whose Banerjee κ is the lobe's κ (what the αr textures
store). A lobe with alpha 0 is empty."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sgpipe.fit._em_jit import em_vmf, kappa_banerjee
from sgpipe.normalmap.lobes import rbar_of_kappa


@njit(cache=True)
def _gather(normals, level, i, j, x):
    """x[:] = the 4^level normals (or feature vectors: any last axis) of texel (i, j)
    (row-major inside the block)."""
    b = 1 << level
    s = 0
    for r in range(i * b, (i + 1) * b):
        for c in range(j * b, (j + 1) * b):
            for a in range(x.shape[1]):
                x[s, a] = normals[r, c, a]
            s += 1


@njit(cache=True)
def _candidates(normals, c_alpha, c_mu, c_rbar, from_normals, i, j, rbar_max, w, m, rb):
    """The 4J lobes of the four finer texels of (i, j) (or its 4 normals when the finer level
    is the map itself) with weights α/4: fills w, m (unit axes), rb (lengths); returns count."""
    n = 0
    for di in range(2):
        for dj in range(2):
            ci, cj = 2 * i + di, 2 * j + dj
            if from_normals:
                w[n] = 0.25
                m[n, 0] = normals[ci, cj, 0]
                m[n, 1] = normals[ci, cj, 1]
                m[n, 2] = normals[ci, cj, 2]
                rb[n] = rbar_max
                n += 1
            else:
                for k in range(c_alpha.shape[2]):
                    if c_alpha[ci, cj, k] > 0.0:
                        w[n] = 0.25 * c_alpha[ci, cj, k]
                        m[n, :] = c_mu[ci, cj, k, :]
                        rb[n] = c_rbar[ci, cj, k]
                        n += 1
    return n


@njit(cache=True)
def hochbaum_shmoys_init(w, m, rb, n, alpha, mu, kappa, kappa_max):
    """Han07 §7.1 initialisation: the J farthest-apart axes among n weighted candidate lobes
    (Hochbaum–Shmoys farthest-first traversal from the heaviest, distance 1 − cos), then each
    candidate joins its nearest chosen axis and a cluster's lobe gets the moments of its
    members: α = Σ w, r = Σ w r_c μ_c / α, κ = Banerjee(|r|)."""
    k_n = alpha.shape[0]
    chosen = np.empty(k_n, np.int64)
    best = 0
    for c in range(1, n):
        if w[c] > w[best]:
            best = c
    chosen[0] = best
    n_ch = 1
    dmin = np.empty(n)
    for c in range(n):
        dmin[c] = 1.0 - (m[c, 0] * m[best, 0] + m[c, 1] * m[best, 1] + m[c, 2] * m[best, 2])
    while n_ch < k_n:
        far = -1
        fd = 1e-12
        for c in range(n):
            if dmin[c] > fd:
                fd = dmin[c]
                far = c
        if far < 0:
            break                                   # the rest duplicate chosen axes
        chosen[n_ch] = far
        n_ch += 1
        for c in range(n):
            d = 1.0 - (m[c, 0] * m[far, 0] + m[c, 1] * m[far, 1] + m[c, 2] * m[far, 2])
            if d < dmin[c]:
                dmin[c] = d
    r = np.zeros((k_n, 3))
    alpha[:] = 0.0
    for c in range(n):
        bk, bd = 0, -2.0
        for k in range(n_ch):
            s = chosen[k]
            d = m[c, 0] * m[s, 0] + m[c, 1] * m[s, 1] + m[c, 2] * m[s, 2]
            if d > bd:
                bd, bk = d, k
        alpha[bk] += w[c]
        for a in range(3):
            r[bk, a] += w[c] * rb[c] * m[c, a]
    for k in range(k_n):
        if k >= n_ch or alpha[k] <= 0.0:
            alpha[k] = 0.0
            mu[k, 0] = 0.0
            mu[k, 1] = 0.0
            mu[k, 2] = 1.0
            kappa[k] = 1.0
            continue
        rl = math.sqrt(r[k, 0] ** 2 + r[k, 1] ** 2 + r[k, 2] ** 2)
        s = chosen[k]
        for a in range(3):
            mu[k, a] = r[k, a] / rl if rl > 0.0 else m[s, a]
        kappa[k] = min(kappa_banerjee(rl / alpha[k]), kappa_max)


@njit(cache=True)
def _finish(alpha, kappa, rbar_out, kappa_max):
    """Lengths to store for the fitted κ's (empty lobes: 0)."""
    for k in range(alpha.shape[0]):
        rbar_out[k] = rbar_of_kappa(min(kappa[k], kappa_max)) if alpha[k] > 0.0 else 0.0


@njit(cache=True)
def _neighbours(alpha, mu, i, j, p_alpha, p_mu, has_parent, nb_a, nb_m):
    """Fills nb_a (≤5, J) / nb_m (≤5, J, 3) with the lobes eq 23 aligns to: the previously
    visited texels of this level in scan-line order (left, up-left, up, up-right) and the
    parent on the coarser level; returns their count."""
    m_side = alpha.shape[0]
    n = 0
    for di, dj in ((0, -1), (-1, -1), (-1, 0), (-1, 1)):
        a, b = i + di, j + dj
        if 0 <= a < m_side and 0 <= b < m_side:
            nb_a[n, :] = alpha[a, b, :]
            nb_m[n, :, :] = mu[a, b, :, :]
            n += 1
    if has_parent:
        nb_a[n, :] = p_alpha[i // 2, j // 2, :]
        nb_m[n, :, :] = p_mu[i // 2, j // 2, :, :]
        n += 1
    return n


@njit(cache=True)
def match_slots(alpha, mu, nb_a, nb_m, n_nb, order):
    """Lobe permutation for coherence: order[b] = the fitted lobe placed in slot b, greedily
    maximising α_a μ_a · T_b with T_b = Σ_k α_kb μ_kb over the neighbours (the eq 23 / appendix
    term P(N(Θ)|Θ)); empty lobes fill the slots left over."""
    k_n = alpha.shape[0]
    t = np.zeros((k_n, 3))
    for k in range(n_nb):
        for b in range(k_n):
            for c in range(3):
                t[b, c] += nb_a[k, b] * nb_m[k, b, c]
    used_a = np.zeros(k_n, np.bool_)
    used_b = np.zeros(k_n, np.bool_)
    order[:] = -1
    for _ in range(k_n):
        ba, bb, bs = -1, -1, -np.inf
        for a in range(k_n):
            if used_a[a] or alpha[a] <= 0.0:
                continue
            for b in range(k_n):
                if used_b[b]:
                    continue
                s = alpha[a] * (mu[a, 0] * t[b, 0] + mu[a, 1] * t[b, 1] + mu[a, 2] * t[b, 2])
                if s > bs:
                    ba, bb, bs = a, b, s
        if ba < 0:
            break
        used_a[ba] = True
        used_b[bb] = True
        order[bb] = ba
    a = 0
    for b in range(k_n):
        if order[b] >= 0:
            continue
        while used_a[a]:
            a += 1
        used_a[a] = True
        order[b] = a


@njit(cache=True)
def match_level(u_alpha, u_mu, u_kappa, u_feat, p_alpha, p_mu, has_parent, alpha, mu, kappa,
                feat):
    """Pass 2a of one level ≥ 1 (coarse → fine, Han07 §7.3): texels in scan-line order, each
    one's pass-1 lobes (u_*, their features u_feat) permuted into the slots of the coarser
    parent and of the previously visited, already permuted neighbours (`match_slots`)."""
    m_side = alpha.shape[0]
    k_n = alpha.shape[2]
    nb_a = np.zeros((5, k_n))
    nb_m = np.zeros((5, k_n, 3))
    order = np.empty(k_n, np.int64)
    for i in range(m_side):
        for j in range(m_side):
            n_nb = _neighbours(alpha, mu, i, j, p_alpha, p_mu, has_parent, nb_a, nb_m)
            match_slots(u_alpha[i, j], u_mu[i, j], nb_a, nb_m, n_nb, order)
            for b in range(k_n):
                alpha[i, j, b] = u_alpha[i, j, order[b]]
                mu[i, j, b, :] = u_mu[i, j, order[b], :]
                kappa[i, j, b] = u_kappa[i, j, order[b]]
                feat[i, j, b, :] = u_feat[i, j, order[b], :]


@njit(cache=True, parallel=True)
def fit_level(normals, feats, level, aligned, c_alpha, c_mu, c_rbar, from_normals, m_alpha,
              m_mu, m_kappa, m_feat, p_alpha, p_mu, has_parent, alpha, mu, kappa, rbar, feat,
              c_align, max_iter, tol, kappa_max):
    """EM of every texel of one level ≥ 1 in parallel (one compiled kernel for both passes).
    feats (N, N, F) holds a feature vector per normal (F may be 0); each lobe's feature, the
    responsibility-weighted mean of its normals' (Han07 eq 22), goes to feat (m, m, J, F).

    Pass 1 (aligned False, fine → coarse): start from Hochbaum–Shmoys on the finer level's
    lobes (c_*; the map's normals when from_normals), no pull. Pass 2b (aligned True): start
    from the matched lobes (m_*, `match_level`) and pull with the eq 23 strength C′ = c_align
    (C = C′/κ_j, the appendix) towards the same neighbours as the matching (their matched
    lobes, so that the texels of a level are independent) and the parent (p_*)."""
    m_side = alpha.shape[0]
    k_n = alpha.shape[2]
    b2 = 1 << (2 * level)
    ones = np.ones(b2)
    n_f = feats.shape[2]
    rbar_max = rbar_of_kappa(kappa_max)
    nc = 4 if from_normals else 4 * c_alpha.shape[2]
    for t in prange(m_side * m_side):
        i = t // m_side
        j = t - i * m_side
        n_nb = 0
        nb5_a = np.zeros((5, k_n))
        nb5_m = np.zeros((5, k_n, 3))
        if aligned:
            alpha[i, j, :] = m_alpha[i, j, :]
            mu[i, j, :, :] = m_mu[i, j, :, :]
            kappa[i, j, :] = m_kappa[i, j, :]
            feat[i, j, :, :] = m_feat[i, j, :, :]
            n_nb = _neighbours(m_alpha, m_mu, i, j, p_alpha, p_mu, has_parent, nb5_a, nb5_m)
        else:
            w = np.empty(nc)
            cm = np.empty((nc, 3))
            rb = np.empty(nc)
            n = _candidates(normals, c_alpha, c_mu, c_rbar, from_normals, i, j, rbar_max, w,
                            cm, rb)
            hochbaum_shmoys_init(w, cm, rb, n, alpha[i, j], mu[i, j], kappa[i, j], kappa_max)
        if not aligned or (c_align > 0.0 and n_nb > 0):
            x = np.empty((b2, 3))
            _gather(normals, level, i, j, x)
            y = np.empty((b2, n_f))
            _gather(feats, level, i, j, y)
            nb_a = nb5_a[:n_nb].copy()
            nb_m = nb5_m[:n_nb].copy()
            em_vmf(x, ones, y, alpha[i, j], mu[i, j], kappa[i, j], nb_a, nb_m,
                   c_align if aligned else 0.0, max_iter, tol, kappa_max, feat[i, j])
        _finish(alpha[i, j], kappa[i, j], rbar[i, j], kappa_max)


@njit(cache=True)
def align_level0(normals, p_alpha, p_mu, has_parent, k_n, slot):
    """Pass 2 at the finest level: each texel is one delta lobe (α = 1, μ = n); slot[i, j] is
    the slot it takes, the one whose neighbour sum T_b (as in `match_slots`) it follows most."""
    m_side = normals.shape[0]
    t = np.zeros((k_n, 3))
    for i in range(m_side):
        for j in range(m_side):
            t[:, :] = 0.0
            for di, dj in ((0, -1), (-1, -1), (-1, 0), (-1, 1)):
                a, b = i + di, j + dj
                if 0 <= a < m_side and 0 <= b < m_side:
                    for c in range(3):
                        t[slot[a, b], c] += normals[a, b, c]
            if has_parent:
                for b in range(k_n):
                    for c in range(3):
                        t[b, c] += p_alpha[i // 2, j // 2, b] * p_mu[i // 2, j // 2, b, c]
            best, bs = 0, -np.inf
            for b in range(k_n):
                s = normals[i, j, 0] * t[b, 0] + normals[i, j, 1] * t[b, 1] \
                    + normals[i, j, 2] * t[b, 2]
                if s > bs:
                    best, bs = b, s
            slot[i, j] = best
