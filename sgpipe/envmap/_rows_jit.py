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
(κ z_h ẑ)²/2, 2e-6 where the weight e^{−z_h−ẑ} is 1e-2 and λ_d = 16384, 4e-4 … 2e-3 there at
λ_d 2048 … 1024 (the pyramid uses rows for λ_d ≥ `ROW_LAMBDA_D_MIN`).

Pass 1 (`row_pass1`) convolves each source row along itself: at sample points x_k of the row
(the output grid's pitch) C0 = Σ E e^{P(ẑ)} and C1 = Σ E ẑ e^{P(ẑ)}, stored as cubic B-spline
coefficients. Pass 2 (`row_pass2`) sums over the rows in reach of each output, with
V = C0 + κ z_h C1 at the foot:

    Γ(p) = Σ_rows e^{P(z_h)} V,    ∂Γ/∂λ = g0 Γ + g1 Σ_rows e^{P(z_h)} (z_h V + cos h · C1)

for a derivative kernel K·(g0 + g1 z) (the SG: g0 = 0, g1 = −1/λ; a difference kernel's g2 z²,
g3 z³ are dropped: the slope only steers the λ interpolation). The foot of p = (s0, t0, 1) on
row t_i lies at s = a·s0, a = (1 + t_i²)/(1 + t0 t_i): off the sample grid, so C is
interpolated there with its B-spline. Along an output row the feet of a block of consecutive
outputs drift by (len − 1)|a − 1| < 1 sample against them, so one base index per block and
five taps cover every lane and the loads stay contiguous (vectorised). Only the face's own rows
are summed; the masses on the other faces are added by the 2-D gather (`_pyramid_jit.sg_gather`
with `skip_own`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sgpipe.envmap._pyramid_jit import E0, _prefilter_rows, fast_exp32_short

NARR = 6            # per row: C0 of 3 channels, C1 of 3 channels
BLOCK = 8           # outputs per base index in pass 2
_F0 = np.float32(0.0)
_F1 = np.float32(1.0)
_F2 = np.float32(2.0)
_F23 = np.float32(2.0 / 3.0)
_FH = np.float32(0.5)
_F16 = np.float32(1.0 / 6.0)
_F3 = np.float32(3.0)
_F6 = np.float32(6.0)
_F8TH = np.float32(0.125)
_F16TH = np.float32(0.0625)
_F5_128 = np.float32(5.0 / 128.0)
_F4 = np.float32(4.0)


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def row_pass1(src, h_src, c0, kern, n_out, x0, m1):
    """C (6, M, NARR, m1) float32: per face and source row (M = src.shape[1] rows and columns,
    centres at c0 + i·h_src in face coordinates), B-spline coefficients of C0 = Σ_j E_j e^{P(ẑ)}
    and C1 = Σ_j E_j ẑ e^{P(ẑ)} (3 channels each) at the row's sample points s_k = x0 + k·h_o
    (h_o = 2/n_out), ẑ = λ_d(1 − c_j·q_k) cut at ẑ ≤ zcut; kern = (λ_d, zcut, k1, k2, k3, k4).
    The masses are the energies of `src` (row blocks) at the grid's centres."""
    n = src.shape[1]
    h_o = 2.0 / n_out
    lam = kern[0]
    zcut = kern[1]
    k1 = np.float32(kern[2])
    k2 = np.float32(kern[3])
    k3 = np.float32(kern[4])
    k4 = np.float32(kern[5])
    cmax = max(-1.0, 1.0 - zcut / lam)
    tau = math.sqrt(max(0.0, 1.0 - cmax * cmax)) / cmax if cmax > 0.0 else 1e3
    out = np.zeros((6, n, NARR, m1), np.float32)
    lamh = np.float32(0.5 * lam)
    zc = np.float32(zcut)
    for job in prange(6 * n):
        f = job // n
        i = job % n
        t = c0 + i * h_src
        q = 1.0 + t * t
        sq = math.sqrt(q)
        # row-local coordinates of the samples: (s/r, √(1 + t²)/r) with r = |(s, t, 1)|, so that
        # |c − q|² is the squared distance of these pairs
        qa = np.empty(m1, np.float32)
        qb = np.empty(m1, np.float32)
        for k in range(m1):
            s = x0 + k * h_o
            r = 1.0 / math.sqrt(q + s * s)
            qa[k] = s * r
            qb[k] = r * sq
        acc = np.zeros((NARR, m1), np.float32)
        row = src[f, i]
        for j in range(n):
            e0 = row[E0, j]
            e1 = row[E0 + 1, j]
            e2 = row[E0 + 2, j]
            if e0 == 0.0 and e1 == 0.0 and e2 == 0.0:
                continue
            u = c0 + j * h_src
            # the window |φ − φ_j| ≤ φ_max along the row (tan φ = s/√(1 + t²)) in s
            den_lo = sq + u * tau
            den_hi = sq - u * tau
            lo = sq * (u - sq * tau) / den_lo if den_lo > 1e-9 else -1e9
            hi = sq * (u + sq * tau) / den_hi if den_hi > 1e-9 else 1e9
            ka = max(0, int(math.ceil((lo - x0) / h_o)))
            kz = min(m1 - 1, int(math.floor((hi - x0) / h_o)))
            r = 1.0 / math.sqrt(q + u * u)
            ca = np.float32(u * r)
            cb = np.float32(r * sq)
            # unsigned indices: numba then emits no negative-index wraparound, which would
            # keep LLVM from vectorising the loop
            uk0 = np.uint64(ka)
            for kk in range(kz - ka + 1):
                k = uk0 + np.uint64(kk)
                da = ca - qa[k]
                db = cb - qb[k]
                z = lamh * (da * da + db * db)
                w = fast_exp32_short(z * (k1 + z * (k2 + z * (k3 + z * k4)))) * (z <= zc)
                wz = w * z
                acc[0, k] += e0 * w
                acc[1, k] += e1 * w
                acc[2, k] += e2 * w
                acc[3, k] += e0 * wz
                acc[4, k] += e1 * wz
                acc[5, k] += e2 * wz
        buf = np.empty((m1, NARR))
        for c in range(NARR):
            for k in range(m1):
                buf[k, c] = acc[c, k]
        _prefilter_rows(buf)
        for c in range(NARR):
            for k in range(m1):
                out[f, i, c, k] = buf[k, c]
    return out


@njit(cache=True, fastmath=True, error_model="numpy")
def _block(p0, q0, p1, q1, p2, q2, a0, b0_, a1, b1_, a2, b2_, us, ir0, kb, jb, blen, d, ai, bi,
           lam32, zc, pk1, pk2, pk3, pk4, kap):
    """Pass 2 for `blen` outputs from jb of one output row and one source row (base index kb):
    per channel c, with the row's pass-1 coefficients (p_c, q_c) = (C0, C1) at the feet and
    V = C0 + κ z_h C1, a_c += e^{P(z_h)} V and b_c += e^{P(z_h)} (z_h V + cos h·C1).
    1-D rows as arguments and unsigned indices: with 2-D indexing (run-time strides, numba's
    negative-index wraparound) the loop stays scalar."""
    ub = np.uint64(kb)
    uj = np.uint64(jb)
    kbf = np.float32(kb)
    for jj in range(blen):
        j = uj + np.uint64(jj)
        k = ub + np.uint64(jj)
        # (written out here: behind an inlined helper returning a tuple the loop stays scalar)
        sh = d * ir0[j]
        x = sh * sh
        # ε = 1 − cos h = x/(1 + √(1 − x)) = x(½ + x(⅛ + x(1/16 + 5x/128))), x = sin²h ≤ T²/λ_d:
        # float32 without cancellation, square root or division
        eps = x * (_FH + x * (_F8TH + x * (_F16TH + x * _F5_128)))
        zh = lam32 * eps
        ch = _F1 - eps
        w = fast_exp32_short(zh * (pk1 + zh * (pk2 + zh * (pk3 + zh * pk4)))) * (zh <= zc)
        kz = kap * zh
        # the foot is 1 … 3 samples past tap kb + jj: the four cubic B-spline weights of its
        # fraction, shifted by one tap when it is past 2
        oj = ai * us[j] + bi - kbf - np.float32(jj)
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
def row_pass2(C, h_src, c0, kern, kappa, g0, g1, n_out, ext, x0, out):
    """out[f, o, j, 0:3] += Γ, out[..., 3:6] += ∂Γ/∂λ at the bordered output texel centres
    (s_j, t_o) = −1 + (j − ext + ½)·2/n_out of a (6, n_out + 2·ext, …) cubemap, from the pass-1
    coefficients C of each face's own rows (t_i = c0 + i·h_src) for the kernel
    kern = (λ_d, zcut, k1, k2, k3, k4), its cross term κ and derivative g0 + g1 z (module
    docstring). The caller checks that the feet drift by < 1 sample per block (`row_plan`)."""
    n = C.shape[1]
    m1 = C.shape[3]
    h_o = 2.0 / n_out
    m = n_out + 2 * ext
    lam = kern[0]
    zcut = kern[1]
    sin_max = min(1.0, math.sqrt(max(0.0, 1.0 - (1.0 - zcut / lam) ** 2)))
    lam32 = np.float32(lam)
    zc = np.float32(zcut)
    k1 = np.float32(kern[2])
    k2 = np.float32(kern[3])
    k3 = np.float32(kern[4])
    k4 = np.float32(kern[5])
    kap = np.float32(kappa)
    nb = (m + BLOCK - 1) // BLOCK
    mp = nb * BLOCK
    for job in prange(6 * m):
        f = job // m
        o = job % m
        t0 = -1.0 + (o - ext + 0.5) * h_o
        us = np.empty(mp, np.float32)
        ir0 = np.empty(mp, np.float32)
        r0max = 0.0
        for j in range(mp):
            u = -1.0 + (j - ext + 0.5) * h_o
            us[j] = u
            r0 = math.sqrt(1.0 + u * u + t0 * t0)
            ir0[j] = 1.0 / r0
            r0max = max(r0max, r0)
        acc = np.zeros((NARR, mp), np.float32)
        i0, i1 = _rows_in_reach(t0, r0max, sin_max, h_src, c0, n)
        for i in range(i0, i1 + 1):
            ti = c0 + i * h_src
            a = (1.0 + ti * ti) / (1.0 + t0 * ti)
            d = np.float32((t0 - ti) / math.sqrt(1.0 + ti * ti))
            ai = np.float32(a / h_o)
            bi = np.float32(-x0 / h_o)
            cr = C[f, i]
            # blocks of outputs sharing a base index: their feet drift by (len − 1)|a − 1| < 1
            # samples against them (5 taps, the foot's fraction takes one); long blocks keep
            # the vector loop busy
            blen_max = max(BLOCK, min(mp, BLOCK * int((1.0 + 0.95 / max(abs(a - 1.0), 1e-9))
                                                      / BLOCK)))
            d2 = np.float64(d) * np.float64(d)
            jb = 0
            while jb < mp:
                blen = min(blen_max, mp - jb)
                je = jb + blen - 1
                # skip a block when even its outputs farthest from the face's centre column
                # (largest r0, smallest angle to the row's plane) are out of reach
                if d2 * min(ir0[jb], ir0[je]) ** 2 > sin_max * sin_max:
                    jb += blen
                    continue
                ta = ai * us[jb] + bi
                tb = ai * us[je] + bi - (blen - 1)
                kb = int(math.floor(min(ta, tb))) - 1
                kb = max(0, min(m1 - blen - 5, kb))
                _block(cr[0], cr[3], cr[1], cr[4], cr[2], cr[5], acc[0], acc[3], acc[1], acc[4],
                       acc[2], acc[5], us, ir0, kb, jb, blen, d, ai, bi, lam32, zc, k1, k2, k3,
                       k4, kap)
                jb += blen
        for j in range(m):
            for c in range(3):
                v = acc[c, j]
                out[f, o, j, c] += v
                out[f, o, j, c + 3] += g0 * v + g1 * acc[c + 3, j]
    return out


@njit(cache=True)
def _rows_in_reach(t0, r0max, sin_max, h_src, c0, n):
    """Source rows [i0, i1] with |t0 − t_i| ≤ sin h_max · r0 · √(1 + t_i²) for some output of the
    output row t0 (r0 ≤ r0max)."""
    tm = abs(t0) + sin_max * r0max * 2.0
    dv = sin_max * r0max * math.sqrt(1.0 + tm * tm)
    i0 = max(0, int(math.ceil((t0 - dv - c0) / h_src)))
    i1 = min(n - 1, int(math.floor((t0 + dv - c0) / h_src)))
    return i0, i1


@njit(cache=True)
def row_plan(n_src, h_src, c0, lam_d, zcut, n_out, ext):
    """(largest |a − 1| over the (output row, source row) pairs pass 2 visits, largest foot offset
    |a·s − s| over their outputs, in face coordinates): the block length and pass-1 margin."""
    h_o = 2.0 / n_out
    m = n_out + 2 * ext
    sin_max = min(1.0, math.sqrt(max(0.0, 1.0 - (1.0 - zcut / lam_d) ** 2)))
    smax = 1.0 + (ext + BLOCK) * h_o
    dev = 0.0
    for o in range(m):
        t0 = -1.0 + (o - ext + 0.5) * h_o
        r0max = math.sqrt(1.0 + smax * smax + t0 * t0)
        i0, i1 = _rows_in_reach(t0, r0max, sin_max, h_src, c0, n_src)
        for i in range(i0, i1 + 1):
            ti = c0 + i * h_src
            dev = max(dev, abs((1.0 + ti * ti) / (1.0 + t0 * ti) - 1.0))
    return dev, dev * smax
