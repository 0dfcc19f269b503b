"""Compiled pass 2 of the row-factorised gather (`rows`): at each output, the sum over the lines
in reach of their pass-1 coefficients interpolated at the output's foot."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sgpipe.envmap.pyramid._exp_jit import exp32_scaled, quartic_exponent
from sgpipe.envmap.pyramid._rows_pass1_jit import NARR, VLOOP

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


@njit(cache=True, fastmath=True, error_model="numpy")
def _block(p0, q0, p1, q1, p2, q2, a0, b0_, a1, b1_, a2, b2_, jf, ir2, kb, jb, blen, d2, dl, c0,
           lam32, zc, e1, e2, e3, e4, kap):
    """Pass 2 for `blen` outputs from jb of one output row and one source row (base index kb):
    per channel c, with the row's pass-1 coefficients (p_c, q_c) = (C0, C1) at the feet and
    V = C0 + κ z_h C1, a_c += e^{P(z_h)} V and b_c += e^{P(z_h)} (z_h V + cos h·C1);
    P(z_h)/32 = x(e1 + e2 x + e3 x² + e4 x³), x = sin²h = d2·ir2[j] (`rows.exponent_poly`).
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
        w = exp32_scaled(quartic_exponent(x, e1, e2, e3, e4)) * (zh <= zc)
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
    coefficients C of the lines (`_lines_jit.build_lines`) for the kernel kern = (λ_d, zcut,
    k1 … k4) (its exponent as `rows.exponent_poly(kern)`), its cross term κ and derivative
    g0 + g1 z (`rows` module docstring); frame r = 1 (columns) writes transposed. Frames
    key_lo … key_hi − 1 only, whose lines are key_off[key_lo] … key_off[key_hi] − 1:
    C[ℓ − key_off[key_lo]] belongs to line ℓ."""
    m1 = C.shape[2]
    h_o = 2.0 / n_out
    m = n_out + 2 * ext
    lam = kern[0]
    zcut = kern[1]
    sin_max = sin_hmax(lam, zcut)
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
def sin_hmax(lam_d, zcut):
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
    sin_max = sin_hmax(lam_d, zcut)
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
