"""Compiled pass 1 of the row-factorised gather (`rows`): each line convolved along itself at the
output pitch, stored as cubic B-spline coefficients."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sgpipe.envmap.pyramid._exp_jit import exp32_scaled, quartic_exponent
from sgpipe.envmap.pyramid._masses_jit import E0
from sgpipe.envmap.pyramid._spline_jit import prefilter_rows

NARR = 6            # per row: C0 of 3 channels, C1 of 3 channels
VLOOP = 16          # LLVM's vector loop here: 8 float32 lanes × 2 interleaved; a shorter trip
                    # count runs scalar


@njit(cache=True, fastmath=True, error_model="numpy")
def _sample(ca, cb, e0, e1, e2, j0, nj, qa, qb, lamh, k1, k2, k3, k4, zc, acc, k):
    """Pass 1 at one sample (row-local qa, qb) over masses j0 … j0 + nj − 1: acc[0:3, k] =
    Σ E e^{P(ẑ)}, acc[3:6, k] = Σ E ẑ e^{P(ẑ)} (k1 … k4: P's coefficients over 32, see
    `quartic_exponent`). A reduction with no stores in the loop (so no run-time alias checks)
    over 1-D rows with unsigned indices (no wraparound code): vectorised."""
    s0 = s1 = s2 = t0 = t1 = t2 = np.float32(0.0)
    uj0 = np.uint64(j0)
    for jj in range(nj):
        j = uj0 + np.uint64(jj)
        da = ca[j] - qa
        db = cb[j] - qb
        z = lamh * (da * da + db * db)
        w = exp32_scaled(quartic_exponent(z, k1, k2, k3, k4)) * (z <= zc)
        wz = w * z
        s0 += e0[j] * w
        s1 += e1[j] * w
        s2 += e2[j] * w
        t0 += e0[j] * wz
        t1 += e1[j] * wz
        t2 += e2[j] * wz
    acc[0, k] = s0
    acc[1, k] = s1
    acc[2, k] = s2
    acc[3, k] = t0
    acc[4, k] = t1
    acc[5, k] = t2


@njit(cache=True)
def _row_local(x0, h, n, t):
    """Row-local coordinates (s/r, √(1 + t²)/r), r = |(s, t, 1)|, of the points s = x0 + k·h of
    the line t: |c − q|² of two points of a line is the squared distance of these pairs."""
    sq = math.sqrt(1.0 + t * t)
    a = np.empty(n, np.float32)
    b = np.empty(n, np.float32)
    for k in range(n):
        s = x0 + k * h
        r = 1.0 / math.sqrt(1.0 + t * t + s * s)
        a[k] = s * r
        b[k] = r * sq
    return a, b


@njit(cache=True)
def _line_samples(acc, ma, mz, m_ca, m_cb, m_s, m_e, qa, qb, x0, h_o, sq, tau, lamh, k1, k2, k3,
                  k4, zc):
    """Pass 1 of any line, sample by sample: the masses ma … mz − 1 (sorted by s) within the
    window |φ − φ_k| ≤ φ_max of each sample (`_sample`)."""
    m1 = acc.shape[1]
    nm = mz - ma
    ca = m_ca[ma:mz]
    cb = m_cb[ma:mz]
    ms = m_s[ma:mz]
    e0 = m_e[0, ma:mz]
    e1 = m_e[1, ma:mz]
    e2 = m_e[2, ma:mz]
    jlo = 0
    jhi = 0
    for k in range(m1):
        u = x0 + k * h_o
        # the window [lo, hi] in s (tan φ = s/√(1 + t²)) moves right with k
        den_lo = sq + u * tau
        den_hi = sq - u * tau
        lo = sq * (u - sq * tau) / den_lo if den_lo > 1e-9 else -1e9
        hi = sq * (u + sq * tau) / den_hi if den_hi > 1e-9 else 1e9
        while jlo < nm and ms[jlo] < lo:
            jlo += 1
        if jhi < jlo:
            jhi = jlo
        while jhi < nm and ms[jhi] <= hi:
            jhi += 1
        n_in = jhi - jlo
        if n_in == 0:
            continue
        # a trip count that is a multiple of VLOOP runs entirely in the vector loop (the extra
        # masses are beyond the cut, weight 0)
        nj = min(nm, (n_in + VLOOP - 1) // VLOOP * VLOOP)
        j0 = max(0, min(jlo, nm - nj))
        _sample(ca, cb, e0, e1, e2, j0, nj, qa[k], qb[k], lamh, k1, k2, k3, k4, zc, acc, k)


@njit(cache=True, fastmath=True, error_model="numpy")
def _diagonal(qa, qb, ca, cb, e0, e1, e2, a0, a1, a2, b0, b1, b2, k0, j0, n, lamh, k1, k2, k3,
              k4, zc):
    """Pass 1 of a row whose masses sit on the sample grid, one mass offset d at a time:
    samples k0 … k0 + n − 1 against masses j0 … j0 + n − 1 (j = k − off + d): a_c += E_c e^{P(ẑ)},
    b_c += E_c ẑ e^{P(ẑ)}. One long vector loop per offset instead of a call per sample."""
    uk = np.uint64(k0)
    uj = np.uint64(j0)
    for i in range(n):
        k = uk + np.uint64(i)
        j = uj + np.uint64(i)
        da = ca[j] - qa[k]
        db = cb[j] - qb[k]
        z = lamh * (da * da + db * db)
        w = exp32_scaled(quartic_exponent(z, k1, k2, k3, k4)) * (z <= zc)
        wz = w * z
        a0[k] += e0[j] * w
        a1[k] += e1[j] * w
        a2[k] += e2[j] * w
        b0[k] += e0[j] * wz
        b1[k] += e1[j] * wz
        b2[k] += e2[j] * wz


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def row_pass1(t_line, m_off, m_ca, m_cb, m_s, m_e, kern, n_out, x0, m1, src, own, c0_src, h_src,
              store):
    """C (L, NARR, m1) float32: per line (`_lines_jit.build_lines`), B-spline coefficients of
    C0 = Σ_j E_j e^{P(ẑ)} and C1 = Σ_j E_j ẑ e^{P(ẑ)} (3 channels each) at the line's sample
    points s_k = x0 + k·h_o (h_o = 2/n_out) in its frame, ẑ = λ_d(1 − c_j·q_k) cut at
    ẑ ≤ zcut; kern = (λ_d, zcut, k1, k2, k3, k4). C lives at the front of `store` (float32,
    at least L·NARR·m1: the caller's buffer, reused from level to level, so the build does not
    fault in fresh pages for it at every level)."""
    n_lines = t_line.shape[0]
    h_o = 2.0 / n_out
    lam = kern[0]
    zcut = kern[1]
    # P's coefficients over 32: the exponent goes to `exp32_scaled` as is
    k1 = np.float32(kern[2] / 32.0)
    k2 = np.float32(kern[3] / 32.0)
    k3 = np.float32(kern[4] / 32.0)
    k4 = np.float32(kern[5] / 32.0)
    cmax = max(-1.0, 1.0 - zcut / lam)
    tau = math.sqrt(max(0.0, 1.0 - cmax * cmax)) / cmax if cmax > 0.0 else 1e3
    out = store[:n_lines * NARR * m1].reshape((n_lines, NARR, m1))
    lamh = np.float32(0.5 * lam)
    zc = np.float32(zcut)
    for ln in prange(n_lines):
        t = t_line[ln]
        q = 1.0 + t * t
        sq = math.sqrt(q)
        qa, qb = _row_local(x0, h_o, m1, t)
        acc = np.zeros((NARR, m1), np.float32)
        off = (c0_src - x0) / h_o               # sample index of mass 0 on an own row
        if own[ln] >= 0 and abs(h_src - h_o) < 1e-12 * h_o and abs(off - round(off)) < 1e-6:
            f = own[ln] // src.shape[1]
            i = own[ln] % src.shape[1]
            n = src.shape[1]
            io = int(round(off))
            ca, cb = _row_local(c0_src, h_src, n, t)
            # the widest window along the row (at its ends): Δs = φ_max (1 + t² + s²)/√(1 + t²)
            smax = max(abs(c0_src), abs(c0_src + (n - 1) * h_src))
            wmax = int(math.ceil(math.atan(tau) * (q + smax * smax) / sq / h_o)) + 2
            row = src[f, i]
            phi = math.atan(tau)
            for dd in range(-wmax, wmax + 1):
                # masses j = k − io + dd, samples k in [0, m1), masses in [0, n)
                ka = max(0, io - dd)
                kz = min(m1, n + io - dd)
                if kz <= ka:
                    continue
                # in reach where the angle of the offset, ≈ |dd|·h·√q/(q + s̄²) at the pair's
                # midpoint s̄, is at most φ_max: everywhere for the near offsets, towards the
                # row's ends only for the far ones (one sample's margin; lanes beyond are
                # weight 0 anyway)
                s2 = (abs(dd) - 1) * h_src * sq / phi - q
                if s2 <= 0.0:
                    _diagonal(qa, qb, ca, cb, row[E0], row[E0 + 1], row[E0 + 2], acc[0], acc[1],
                              acc[2], acc[3], acc[4], acc[5], ka, ka - io + dd, kz - ka, lamh,
                              k1, k2, k3, k4, zc)
                    continue
                smin = math.sqrt(s2)
                mid = x0 + 0.5 * dd * h_src         # s̄ of sample k: mid + k·h_o
                # [ka, kl): s̄ ≤ −smin; [kr, kz): s̄ ≥ smin
                kl = max(ka, min(kz, int(math.floor((-smin - mid) / h_o)) + 2))
                kr = max(kl, min(kz, int(math.ceil((smin - mid) / h_o)) - 1))
                if kl > ka:
                    _diagonal(qa, qb, ca, cb, row[E0], row[E0 + 1], row[E0 + 2], acc[0], acc[1],
                              acc[2], acc[3], acc[4], acc[5], ka, ka - io + dd, kl - ka, lamh,
                              k1, k2, k3, k4, zc)
                if kz > kr:
                    _diagonal(qa, qb, ca, cb, row[E0], row[E0 + 1], row[E0 + 2], acc[0], acc[1],
                              acc[2], acc[3], acc[4], acc[5], kr, kr - io + dd, kz - kr, lamh,
                              k1, k2, k3, k4, zc)
        else:
            _line_samples(acc, m_off[ln], m_off[ln + 1], m_ca, m_cb, m_s, m_e, qa, qb, x0, h_o,
                          sq, tau, lamh, k1, k2, k3, k4, zc)
        buf = np.empty((m1, NARR))
        for c in range(NARR):
            for k in range(m1):
                buf[k, c] = acc[c, k]
        prefilter_rows(buf)
        for c in range(NARR):
            for k in range(m1):
                out[ln, c, k] = buf[k, c]
    return out
