"""Compiled lines of the row-factorised gather (`rows`): every face's two pencils of great
circles with the source masses on them, the neighbouring faces' included."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sgpipe.envmap.pyramid._masses_jit import CX, E0


@njit(cache=True)
def _frame(uva, key):
    """(U, V, A) of frame key = 2f + r: r = 0 face f's rows, r = 1 its columns (U, V swapped)."""
    f = key // 2
    r = key % 2
    return uva[f, r], uva[f, 1 - r], uva[f, 2]


@njit(cache=True)
def _candidates(uva, m):
    """Candidate lines (key, g, family, index): frame key's own rows (r = 0 only) and the rows
    (family 0) or columns (family 1) of the faces g across the frame's edges parallel to U whose
    planes contain U."""
    out = np.empty((12 * 3 * m, 4), np.int64)
    n = 0
    for key in range(12):
        f = key // 2
        U, V, _ = _frame(uva, key)
        for g in range(6):
            if g == f:
                if key % 2 == 1:
                    continue
                fam = 0
            else:
                if abs(np.dot(uva[g, 2], V)) < 0.5:
                    continue            # g is not across an edge parallel to U
                fam = 0 if abs(np.dot(uva[g, 0], U)) > 0.5 else 1
            for i in range(m):
                out[n, 0] = key
                out[n, 1] = g
                out[n, 2] = fam
                out[n, 3] = i
                n += 1
    return out[:n]


def build_lines(src, uva, t_lim, min_ca, take=None):
    """The source masses of every face's two row pencils as lines (`rows` module docstring).

    Frame key = 2f + r of face f: r = 0 (U, V, A) = (U_f, V_f, A_f), its rows; r = 1
    (V_f, U_f, A_f), its columns. A line of a frame is a plane through U holding masses: f's own
    rows (r = 0 only), and the rows or columns of the two faces across f's edges parallel to U
    whose planes also contain U (every neighbour has one such family), |t| ≤ t_lim, masses with
    c·A > min_ca (the rest is out of any sharp kernel's reach). Returns (key_off (13,), order,
    t, m_off, m_ca, m_cb, m_s, m_e): lines of frame k at order[key_off[k]:key_off[k+1]] sorted
    by their frame coordinate t; masses of line ℓ at [m_off[ℓ], m_off[ℓ+1]) with row-local
    coordinates (c·U, √(1+t²)·c·A), position s = c·U/c·A and energies m_e (3, ·); own[ℓ] =
    f·M + i for face f's own row i (M = rows per face), −1 for a neighbour's line.

    Two compiled passes (`_lines_count`, `_lines_fill`); the mass arrays come from numpy
    (huge-page advised: the map's lines are large, and every fresh 4 KB page costs a fault) or
    from take(name, shape) (float32 buffers the caller reuses)."""
    cand, tc, cnt = _lines_count(src, uva, t_lim, min_ca)
    n_mass = int(cnt.sum())
    if take is None:
        take = lambda name, shape: np.empty(shape, np.float32)     # noqa: E731
    m_ca = take("ca", (n_mass,))
    m_cb = take("cb", (n_mass,))
    m_s = take("s", (n_mass,))
    m_e = take("e", (3, n_mass))
    return _lines_fill(src, uva, cand, tc, cnt, min_ca, m_ca, m_cb, m_s, m_e)


@njit(cache=True, inline="always")
def _line_mass(src, g, fam, i, j, A, min_ca):
    """Mass j of candidate line (g, fam, i) (`_candidates`): (kept, cx, cy, cz, c·A, energies);
    kept unless its energy is zero or c·A ≤ min_ca (out of any sharp kernel's reach). The one
    rule `_lines_count` counts by and `_lines_fill` writes by."""
    a_ = i if fam == 0 else j
    b_ = j if fam == 0 else i
    e0, e1, e2 = src[g, a_, E0, b_], src[g, a_, E0 + 1, b_], src[g, a_, E0 + 2, b_]
    cx, cy, cz = src[g, a_, CX, b_], src[g, a_, CX + 1, b_], src[g, a_, CX + 2, b_]
    ca_ = cx * A[0] + cy * A[1] + cz * A[2]
    kept = not (e0 == 0.0 and e1 == 0.0 and e2 == 0.0) and ca_ > min_ca
    return kept, cx, cy, cz, ca_, e0, e1, e2


@njit(cache=True, parallel=True)
def _lines_count(src, uva, t_lim, min_ca):
    """Candidate lines (`_candidates`), their frame coordinate t and mass count (0: none or
    beyond t_lim)."""
    m = src.shape[1]
    cand = _candidates(uva, m)
    nc = cand.shape[0]
    tc = np.empty(nc)
    cnt = np.zeros(nc, np.int64)
    for q in prange(nc):
        U, V, A = _frame(uva, cand[q, 0])
        g, fam, i = cand[q, 1], cand[q, 2], cand[q, 3]
        tl = 1e30
        c = 0
        for j in range(m):
            kept, cx, cy, cz, ca_, _, _, _ = _line_mass(src, g, fam, i, j, A, min_ca)
            if not kept:
                continue
            if c == 0:
                # the line's frame coordinate (the same for every point of its plane)
                tl = (cx * V[0] + cy * V[1] + cz * V[2]) / ca_
                if abs(tl) > t_lim:
                    break
            c += 1
        tc[q] = tl
        cnt[q] = c if abs(tl) <= t_lim else 0
    return cand, tc, cnt


@njit(cache=True, parallel=True)
def _lines_fill(src, uva, cand, tc, cnt, min_ca, m_ca, m_cb, m_s, m_e):
    """`build_lines` after `_lines_count`: the kept lines, sorted by t per frame, with their
    masses written into m_ca, m_cb, m_s, m_e (sized for cnt.sum())."""
    m = src.shape[1]
    # keep the lines with masses, grouped by frame (candidates come in key order)
    keep = np.nonzero(cnt > 0)[0]
    n_lines = keep.shape[0]
    own = np.full(n_lines, -1, np.int64)
    for ln in range(n_lines):
        q = keep[ln]
        if cand[q, 1] == cand[q, 0] // 2:
            own[ln] = cand[q, 1] * m + cand[q, 3]
    t = np.empty(n_lines)
    m_off = np.zeros(n_lines + 1, np.int64)
    key_off = np.zeros(13, np.int64)
    for ln in range(n_lines):
        q = keep[ln]
        t[ln] = tc[q]
        m_off[ln + 1] = m_off[ln] + cnt[q]
        key_off[cand[q, 0] + 1] = ln + 1
    for key in range(12):
        key_off[key + 1] = max(key_off[key + 1], key_off[key])
    for ln in prange(n_lines):
        q = keep[ln]
        U, V, A = _frame(uva, cand[q, 0])
        g, fam, i = cand[q, 1], cand[q, 2], cand[q, 3]
        sq = math.sqrt(1.0 + t[ln] * t[ln])
        mi = m_off[ln]
        for j in range(m):
            kept, cx, cy, cz, ca_, e0, e1, e2 = _line_mass(src, g, fam, i, j, A, min_ca)
            if not kept:
                continue
            cu = cx * U[0] + cy * U[1] + cz * U[2]
            m_ca[mi] = cu
            m_cb[mi] = sq * ca_
            m_s[mi] = cu / ca_
            m_e[0, mi] = e0
            m_e[1, mi] = e1
            m_e[2, mi] = e2
            mi += 1
        a = m_off[ln]
        b = mi - 1
        if m_s[a] > m_s[b]:         # masses by increasing s (a neighbour's axis may point back)
            while a < b:
                m_ca[a], m_ca[b] = m_ca[b], m_ca[a]
                m_cb[a], m_cb[b] = m_cb[b], m_cb[a]
                m_s[a], m_s[b] = m_s[b], m_s[a]
                for c in range(3):
                    m_e[c, a], m_e[c, b] = m_e[c, b], m_e[c, a]
                a += 1
                b -= 1
    order = np.empty(n_lines, np.int64)
    for key in range(12):
        a = key_off[key]
        b = key_off[key + 1]
        o = np.argsort(t[a:b])
        for k in range(b - a):
            order[a + k] = a + o[k]
    return key_off, order, t, m_off, m_ca, m_cb, m_s, m_e, own
