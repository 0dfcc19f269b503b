"""Row-factorised zonal gather: the sharp Γ_L levels in two cheap passes instead of one 2-D
sum per output (compiled cores; the wrapper is `pyramid._row_gather`).

Every row of a cube face (t = const, also beyond the face) is a great circle. For a mass c on
the row circle C and an output p at angle h from C's plane, with φ the angle along C between c
and p's foot point on C, spherical Pythagoras gives c·p = cos h · cos φ. For a zonal kernel
K = exp(P(z)), z = λ_d(1 − c·p), P(z) = k1 z + k2 z² + k3 z³ + k4 z⁴ (the SG: λ_d = λ, P = −z;
a chain step's difference kernel: `sgkernel.difference_kernel`):

    z = z_h + cos h · ẑ,   z_h = λ_d(1 − cos h),  ẑ = λ_d(1 − cos φ),  cos h = 1 − z_h/λ_d
    K = e^{P(z_h)} e^{P(ẑ)} e^{D},   D = z_h ẑ (2k2 − k1/λ_d) + O(k3 z_h ẑ (z_h + ẑ), z_h ẑ²/λ_d²)

(the SG: D = z_h ẑ/λ_d exactly). With κ = 2k2 − k1/λ_d, e^D ≈ 1 + κ z_h ẑ: relative error
(κ z_h ẑ)²/2, 2e-6 where the weight e^{−z_h−ẑ} is 1e-2 and λ_d = 16384 (the pyramid uses rows
down to λ_d = `PyramidSettings.rows_lambda_min`, 500: on 256² maps the rows' levels are as
close to brute force as the 2-D gather's or closer).

Pass 1 (`row_pass1`) convolves each line along itself: at sample points x_k of the line (the
output grid's pitch) C0 = Σ E e^{P(ẑ)} and C1 = Σ E ẑ e^{P(ẑ)}, stored as cubic B-spline
coefficients. Pass 2 (`row_pass2`) sums over the lines in reach of each output, with
V = C0 + κ z_h C1 at the foot:

    Γ(p) = Σ_lines e^{P(z_h)} V,    ∂Γ/∂λ = g0 Γ + g1 Σ_lines e^{P(z_h)} (z_h V + cos h · C1)

for a derivative kernel K·(g0 + g1 z) (the SG: g0 = 0, g1 = −1/λ; a difference kernel's g2 z²,
g3 z³ are dropped: the slope only steers the λ interpolation). The foot of p = (s0, t0, 1) on
the line t_i lies at s = a·s0, a = (1 + t_i²)/(1 + t0 t_i): off the sample grid, so C is
interpolated there with its B-spline. Along an output row the feet of a block of consecutive
outputs drift by (len − 1)|a − 1| < 1 sample against them, so one base index per block and
five taps cover every lane and the loads stay contiguous (vectorised).

Seams: the rows of a face (t = const in its gnomonic plane) are the pencil of planes through its
U axis; a neighbouring face across an edge parallel to U has a family of rows or columns in the
same pencil, so its masses are lines of this face's frame too (at |t| > 1, or inside for a
chained level's extended grid). Each face is summed in two frames, rows (U, V) with its own
masses and the two neighbours across its t-edges, and columns (V, U) with the neighbours across
its s-edges (written transposed): every mass of the sphere within reach, no 2-D fallback at the
seams (`build_lines`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sgpipe.envmap._pyramid_jit import CX, E0, _prefilter_rows, exp32_scaled

NARR = 6            # per row: C0 of 3 channels, C1 of 3 channels
VLOOP = 16          # LLVM's vector loop here: 8 float32 lanes × 2 interleaved; a shorter trip
                    # count runs scalar (8 outputs: 30 ns per output and line, 512: 3.5 ns)
_F1 = np.float32(1.0)
_F2 = np.float32(2.0)
_FH = np.float32(0.5)
_F16 = np.float32(1.0 / 6.0)
_F3 = np.float32(3.0)
_F6 = np.float32(6.0)
_F8TH = np.float32(0.125)
_F16TH = np.float32(0.0625)
_F5_128 = np.float32(5.0 / 128.0)
_F4 = np.float32(4.0)


@njit(cache=True, fastmath=True, inline="always")
def _exponent(z, c1, c2, c3, c4):
    """z(c1 + c2 z + c3 z² + c4 z³), written in Estrin's form for a short dependency chain (the
    inner loops here are bound by one lane's exponent → exp → accumulation chain, not by their
    operation count); fastmath lets LLVM reassociate it, and in `_sample` it emits Horner's."""
    return z * ((c1 + z * c2) + (z * z) * (c3 + z * c4))


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
    """The source masses of every face's two row pencils as lines (the module docstring).

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
    (huge-page advised: a fresh 4 KB page costs 2–3 µs to fault in, and the map's lines are
    ~50 MB at 512²) or from take(name, shape) (float32 buffers the caller reuses)."""
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


@njit(cache=True, fastmath=True, error_model="numpy")
def _sample(ca, cb, e0, e1, e2, j0, nj, qa, qb, lamh, k1, k2, k3, k4, zc, acc, k):
    """Pass 1 at one sample (row-local qa, qb) over masses j0 … j0 + nj − 1: acc[0:3, k] =
    Σ E e^{P(ẑ)}, acc[3:6, k] = Σ E ẑ e^{P(ẑ)} (k1 … k4: P's coefficients over 32, see
    `_exponent`). A reduction with no stores in the loop (so no run-time alias checks) over 1-D
    rows with unsigned indices (no wraparound code): vectorised."""
    s0 = s1 = s2 = t0 = t1 = t2 = np.float32(0.0)
    uj0 = np.uint64(j0)
    for jj in range(nj):
        j = uj0 + np.uint64(jj)
        da = ca[j] - qa
        db = cb[j] - qb
        z = lamh * (da * da + db * db)
        w = exp32_scaled(_exponent(z, k1, k2, k3, k4)) * (z <= zc)
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
        w = exp32_scaled(_exponent(z, k1, k2, k3, k4)) * (z <= zc)
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
    """C (L, NARR, m1) float32: per line (`build_lines`), B-spline coefficients of
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
        _prefilter_rows(buf)
        for c in range(NARR):
            for k in range(m1):
                out[ln, c, k] = buf[k, c]
    return out


@njit(cache=True, fastmath=True, error_model="numpy")
def _block(p0, q0, p1, q1, p2, q2, a0, b0_, a1, b1_, a2, b2_, jf, ir2, kb, jb, blen, d2, dl, c0,
           lam32, zc, e1, e2, e3, e4, kap):
    """Pass 2 for `blen` outputs from jb of one output row and one source row (base index kb):
    per channel c, with the row's pass-1 coefficients (p_c, q_c) = (C0, C1) at the feet and
    V = C0 + κ z_h C1, a_c += e^{P(z_h)} V and b_c += e^{P(z_h)} (z_h V + cos h·C1);
    P(z_h)/32 = x(e1 + e2 x + e3 x² + e4 x³), x = sin²h = d2·ir2[j] (`exponent_poly`).
    1-D rows as arguments and unsigned indices: with 2-D indexing (run-time strides, numba's
    negative-index wraparound) the loop stays scalar."""
    ub = np.uint64(kb)
    uj = np.uint64(jb)
    jbf = np.float32(jb)
    for jj in range(blen):
        j = uj + np.uint64(jj)
        k = ub + np.uint64(jj)
        # (written out here: behind an inlined helper returning a tuple the loop stays scalar)
        x = d2 * ir2[j]
        # ε = 1 − cos h = x/(1 + √(1 − x)) = x(½ + x(⅛ + x(1/16 + 5x/128))), x = sin²h ≤ T²/λ_d:
        # float32 without cancellation, square root or division (z_h and cos h are off the
        # weight's chain: the exponent is a polynomial in x of its own)
        eps = x * (_FH + x * (_F8TH + x * (_F16TH + x * _F5_128)))
        zh = lam32 * eps
        ch = _F1 - eps
        w = exp32_scaled(_exponent(x, e1, e2, e3, e4)) * (zh <= zc)
        kz = kap * zh
        # the foot is 1 … 3 samples past tap kb + jj: the four cubic B-spline weights of its
        # fraction, shifted by one tap when it is past 2
        # (from the float array jf[j] = j: converting the integer lane index to float costs
        # ~40 instructions per 8 lanes without AVX-512)
        oj = dl * (jf[j] - jbf) + c0
        sft = np.float32(oj >= _F2)
        t = oj - _F1 - sft
        t2 = t * t
        t3 = t2 * t
        u = _F1 - t
        w0 = _F16 * u * u * u
        w1 = _F16 * (_F3 * t3 - _F6 * t2 + _F4)
        w2 = _F16 * (_F3 * (t + t2 - t3) + _F1)
        w3 = _F16 * t3
        nsf = _F1 - sft
        b0 = nsf * w0
        b1 = sft * w0 + nsf * w1
        b2 = sft * w1 + nsf * w2
        b3 = sft * w2 + nsf * w3
        b4 = sft * w3
        k1 = k + np.uint64(1)
        k2 = k + np.uint64(2)
        k3 = k + np.uint64(3)
        k4 = k + np.uint64(4)
        s0 = b0 * p0[k] + b1 * p0[k1] + b2 * p0[k2] + b3 * p0[k3] + b4 * p0[k4]
        s1 = b0 * q0[k] + b1 * q0[k1] + b2 * q0[k2] + b3 * q0[k3] + b4 * q0[k4]
        v = s0 + kz * s1
        a0[j] += w * v
        b0_[j] += w * (zh * v + ch * s1)
        s0 = b0 * p1[k] + b1 * p1[k1] + b2 * p1[k2] + b3 * p1[k3] + b4 * p1[k4]
        s1 = b0 * q1[k] + b1 * q1[k1] + b2 * q1[k2] + b3 * q1[k3] + b4 * q1[k4]
        v = s0 + kz * s1
        a1[j] += w * v
        b1_[j] += w * (zh * v + ch * s1)
        s0 = b0 * p2[k] + b1 * p2[k1] + b2 * p2[k2] + b3 * p2[k3] + b4 * p2[k4]
        s1 = b0 * q2[k] + b1 * q2[k1] + b2 * q2[k2] + b3 * q2[k3] + b4 * q2[k4]
        v = s0 + kz * s1
        a2[j] += w * v
        b2_[j] += w * (zh * v + ch * s1)


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def row_pass2(C, key_off, order, t_line, kern, ecoef, kappa, g0, g1, n_out, ext, x0, out,
              key_lo, key_hi):
    """out[f, o, j, 0:3] += Γ, out[..., 3:6] += ∂Γ/∂λ at the bordered output texel centres
    (s_j, t_o) = −1 + (j − ext + ½)·2/n_out of a (6, n_out + 2·ext, …) cubemap, from the pass-1
    coefficients C of the lines (`build_lines`) for the kernel kern = (λ_d, zcut, k1 … k4) (its
    exponent as `exponent_poly(kern)`), its cross term κ and derivative g0 + g1 z (module
    docstring); frame r = 1 (columns) writes transposed. Frames key_lo … key_hi − 1 only, whose
    lines are key_off[key_lo] … key_off[key_hi] − 1: C[ℓ − key_off[key_lo]] belongs to line ℓ."""
    m1 = C.shape[2]
    h_o = 2.0 / n_out
    m = n_out + 2 * ext
    lam = kern[0]
    zcut = kern[1]
    sin_max = _sin_hmax(lam, zcut)
    lam32 = np.float32(lam)
    zc = np.float32(zcut)
    e1 = np.float32(ecoef[0])
    e2 = np.float32(ecoef[1])
    e3 = np.float32(ecoef[2])
    e4 = np.float32(ecoef[3])
    kap = np.float32(kappa)
    bi = -x0 / h_o                  # foot position → sample index: ai·s + bi
    ln0 = key_off[key_lo]
    for job in prange((key_hi - key_lo) * m):
        key = key_lo + job // m
        f = key // 2
        r = key % 2
        o = job % m
        t0 = -1.0 + (o - ext + 0.5) * h_o
        r0max = math.sqrt(1.0 + t0 * t0 + (1.0 + (ext + 0.5) * h_o) ** 2)
        p0, p1 = _lines_in_reach(t_line, order, key_off[key], key_off[key + 1], t0, r0max,
                                 sin_max)
        if p0 > p1:
            continue
        jf = np.empty(m, np.float32)
        ir2 = np.empty(m, np.float32)
        for j in range(m):
            u = -1.0 + (j - ext + 0.5) * h_o
            jf[j] = j
            ir2[j] = 1.0 / (1.0 + u * u + t0 * t0)
        acc = np.zeros((NARR, m), np.float32)
        # 1-D row views made once (each view creation is an atomic reference count)
        a0, a1, a2, b0, b1, b2 = acc[0], acc[1], acc[2], acc[3], acc[4], acc[5]
        for pos in range(p0, p1 + 1):
            ln = order[pos]
            ti = t_line[ln]
            a = (1.0 + ti * ti) / (1.0 + t0 * ti)
            d2 = (t0 - ti) * (t0 - ti) / (1.0 + ti * ti)     # sin²h = d2 / r0²
            ai = a / h_o
            dl = np.float32(a - 1.0)
            cl = ln - ln0
            v0, v1, v2, w0, w1, w2 = C[cl, 0], C[cl, 1], C[cl, 2], C[cl, 3], C[cl, 4], C[cl, 5]
            # blocks of outputs sharing a base index kb: lane jj's foot is o = 1 … 3 samples
            # past tap kb + jj (5 taps: the fraction takes one) and drifts by a − 1 per lane;
            # kb puts the first lane at 1 + frac (a ≥ 1) or 2 + frac (a < 1), so a block may
            # drift by 2 − frac or 1 + frac, 1.5 on average. Long blocks, a multiple of VLOOP,
            # run entirely in the vector loop; near the corners, where the lines fan out,
            # shorter ones
            delta = a - 1.0
            ad = max(abs(delta), 1e-9)
            jb = 0
            while jb < m:
                ta = ai * (-1.0 + (jb - ext + 0.5) * h_o) + bi
                fl = math.floor(ta)
                frac = ta - fl
                if delta >= 0.0:
                    kb = int(fl) - 1
                    room = 1.99 - frac
                else:
                    kb = int(fl) - 2
                    room = 0.99 + frac
                blen = 1 + int(room / ad)
                if blen >= VLOOP:
                    blen -= blen % VLOOP
                blen = min(blen, m - jb)
                je = jb + blen - 1
                # skip a block when even its outputs farthest from the face's centre column
                # (largest r0, smallest angle to the row's plane) are out of reach
                if d2 * min(ir2[jb], ir2[je]) > sin_max * sin_max:
                    jb += blen
                    continue
                kb = max(0, min(m1 - blen - 5, kb))
                _block(v0, w0, v1, w1, v2, w2, a0, b0, a1, b1, a2, b2, jf, ir2, kb, jb, blen,
                       np.float32(d2), dl, np.float32(ta - kb), lam32, zc, e1, e2, e3, e4, kap)
                jb += blen
        for j in range(m):
            for c in range(3):
                v = acc[c, j]
                dv = g0 * v + g1 * acc[c + 3, j]
                if r == 0:
                    out[f, o, j, c] += v
                    out[f, o, j, c + 3] += dv
                else:
                    out[f, j, o, c] += v
                    out[f, j, o, c + 3] += dv
    return out


@njit(cache=True)
def _sin_hmax(lam_d, zcut):
    """sin h of the farthest line in reach: z_h = λ_d(1 − cos h) ≤ zcut."""
    return min(1.0, math.sqrt(max(0.0, 1.0 - (1.0 - zcut / lam_d) ** 2)))


@njit(cache=True)
def _lines_in_reach(t_line, order, a, b, t0, r0max, sin_max):
    """Positions [p0, p1] in order[a:b] (sorted by t) of the lines with
    |t0 − t_i| ≤ sin h_max · r0 · √(1 + t_i²) for some output of the output row t0."""
    lo = a
    hi = b
    tm = abs(t0) + 4.0 * sin_max * r0max
    dv = sin_max * r0max * math.sqrt(1.0 + tm * tm)
    # first position with t ≥ t0 − dv, last with t ≤ t0 + dv (binary searches)
    x = t0 - dv
    while lo < hi:
        mid = (lo + hi) // 2
        if t_line[order[mid]] < x:
            lo = mid + 1
        else:
            hi = mid
    p0 = lo
    lo = p0
    hi = b
    x = t0 + dv
    while lo < hi:
        mid = (lo + hi) // 2
        if t_line[order[mid]] <= x:
            lo = mid + 1
        else:
            hi = mid
    return p0, lo - 1


@njit(cache=True)
def lines_foot(key_off, order, t_line, lam_d, zcut, n_out, ext):
    """Largest offset |a·s − s| of an output's foot from the output (face coordinates) over the
    (output row, line) pairs pass 2 visits: the pass-1 samples needed beyond the outputs."""
    h_o = 2.0 / n_out
    m = n_out + 2 * ext
    sin_max = _sin_hmax(lam_d, zcut)
    smax = 1.0 + (ext + 0.5) * h_o
    dev = 0.0
    for key in range(12):
        for o in range(m):
            t0 = -1.0 + (o - ext + 0.5) * h_o
            r0max = math.sqrt(1.0 + smax * smax + t0 * t0)
            p0, p1 = _lines_in_reach(t_line, order, key_off[key], key_off[key + 1], t0, r0max,
                                     sin_max)
            for pos in range(p0, p1 + 1):
                ti = t_line[order[pos]]
                dev = max(dev, abs((1.0 + ti * ti) / (1.0 + t0 * ti) - 1.0))
    return dev * smax


def exponent_poly(kern) -> np.ndarray:
    """(e1, e2, e3, e4) with P(z_h)/32 ≈ x(e1 + e2 x + e3 x² + e4 x³), x = sin²h, z_h =
    λ_d(1 − cos h), over x in [0, sin²h_max] (pass 2's line weight in one polynomial instead of
    ε(x), then P(z_h): half the dependency chain). Least squares on Chebyshev nodes; within
    1e-8 of the exact exponent for the SG and the pyramid's difference kernels (the series
    ε(x) to x⁴ it replaces: up to 1.5e-6 at λ_d = 500)."""
    lam, zcut = float(kern[0]), float(kern[1])
    xm = _sin_hmax(lam, zcut) ** 2
    x = 0.5 * xm * (1.0 - np.cos(np.pi * (np.arange(64) + 0.5) / 64))
    eps = x / (1.0 + np.sqrt(1.0 - x))
    z = lam * eps
    p = z * (kern[2] + z * (kern[3] + z * (kern[4] + z * kern[5])))
    y = x / xm                                              # well-conditioned basis
    c, *_ = np.linalg.lstsq(np.stack([y ** n for n in range(1, 5)], axis=1), p / 32.0,
                            rcond=None)
    return np.ascontiguousarray(c / xm ** np.arange(1, 5))


def reach_t(lam_d: float, zcut: float, n_out: int, ext: int) -> float:
    """Largest |t| of a line any bordered output can reach (for `build_lines`)."""
    h_o = 2.0 / n_out
    sin_max = _sin_hmax(lam_d, zcut)
    e = 1.0 + (ext + 0.5) * h_o
    r0 = math.sqrt(1.0 + 2.0 * e * e)
    t = e
    for _ in range(3):
        t = e + sin_max * r0 * math.sqrt(1.0 + t * t)
    return t
