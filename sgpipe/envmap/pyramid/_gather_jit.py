"""Compiled 2-D gather of the Γ_L pyramid (Wang09 eq 34–35): Γ and ∂Γ/∂λ at every output texel
as a sum over the point masses in reach (`_masses_jit` row blocks), tile by tile."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from sgpipe.envmap._cube_jit import face_dir
from sgpipe.envmap.pyramid._exp_jit import exp32_scaled, fast_exp32
from sgpipe.envmap.pyramid._masses_jit import CX, CY, CZ, E0, E1, E2, S2

_F1 = np.float32(1.0)
_FH = np.float32(0.5)


@njit(cache=True)
def _tile_rows(uva, g, px, py, pz, cos_r, sin_r, h, c0, m):
    """Row range [i0, i1] of face g that a cap (p, R) can meet (i0 > i1: none); the source
    grid has m rows and columns with centres at c0 + i·h (face coordinates, may extend beyond
    the face).

    The cap boundary is sampled on a circumscribed 16-gon and projected gnomonically; points
    at or behind the face plane are pushed to 'infinity' along their tangential direction.
    """
    ax, ay, az = uva[g, 2, 0], uva[g, 2, 1], uva[g, 2, 2]
    ca = px * ax + py * ay + pz * az
    if sin_r < 0.95:
        e = max(1.0, -(c0 - 0.5 * h), c0 + (m - 0.5) * h)
        cc = 1.0 / np.sqrt(1.0 + 2.0 * e * e)      # widest angle of the grid from the axis
        cos_lim = cc * cos_r - np.sqrt(1.0 - cc * cc) * sin_r
        if ca < cos_lim:
            return 1, 0
    if abs(px) < 0.9:
        hx, hy, hz = 1.0, 0.0, 0.0
    else:
        hx, hy, hz = 0.0, 1.0, 0.0
    e1x = hy * pz - hz * py
    e1y = hz * px - hx * pz
    e1z = hx * py - hy * px
    nn = np.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    e1x /= nn
    e1y /= nn
    e1z /= nn
    e2x = py * e1z - pz * e1y
    e2y = pz * e1x - px * e1z
    e2z = px * e1y - py * e1x
    K = 16
    grow = sin_r / np.cos(np.pi / K)
    smin = tmin = 1e30
    smax = tmax = -1e30
    for k in range(K + 1):
        if k == K:
            vx, vy, vz = px, py, pz
        else:
            ang = 2.0 * np.pi * k / K
            ca_, sa_ = np.cos(ang) * grow, np.sin(ang) * grow
            vx = px * cos_r + ca_ * e1x + sa_ * e2x
            vy = py * cos_r + ca_ * e1y + sa_ * e2y
            vz = pz * cos_r + ca_ * e1z + sa_ * e2z
        ma = vx * ax + vy * ay + vz * az
        a = vx * uva[g, 0, 0] + vy * uva[g, 0, 1] + vz * uva[g, 0, 2]
        b = vx * uva[g, 1, 0] + vy * uva[g, 1, 1] + vz * uva[g, 1, 2]
        if ma > 1e-3 * (abs(a) + abs(b)):
            sc = a / ma
            tc = b / ma
        else:
            sc = 1e3 * a
            tc = 1e3 * b
        smin = min(smin, sc)
        smax = max(smax, sc)
        tmin = min(tmin, tc)
        tmax = max(tmax, tc)
    lo = c0 - 0.5 * h
    hi = c0 + (m - 0.5) * h
    if smax < lo or smin > hi or tmax < lo or tmin > hi:
        return 1, 0
    i0 = int(np.floor((max(tmin, lo) - c0) / h + 0.5))
    i1 = int(np.floor((min(tmax, hi) - c0) / h + 0.5))
    return max(0, i0), min(m - 1, i1)


@njit(cache=True)
def _row_interval(uva, g, px, py, pz, tc, k, h, c0, m):
    """Columns [j0, j1] of the row at face coordinate tc whose centres satisfy c·p >= k
    (solves (a + b·sc)² = k²(q + sc²) on the row's great circle; k > 0)."""
    a = (px * uva[g, 2, 0] + py * uva[g, 2, 1] + pz * uva[g, 2, 2]
         + tc * (px * uva[g, 1, 0] + py * uva[g, 1, 1] + pz * uva[g, 1, 2]))
    b = px * uva[g, 0, 0] + py * uva[g, 0, 1] + pz * uva[g, 0, 2]
    q = 1.0 + tc * tc
    k2 = k * k
    A = b * b - k2
    B = a * b
    Cc = a * a - k2 * q
    # A < 0 (the usual small-cap case): the arc is between the roots of A s² + 2 B s + Cc = 0
    # (if the midpoint is on the cap's side, a + b s > 0). Otherwise take the whole row: the
    # per-tap test in `_accumulate_row` / `_accumulate_poly` keeps the sum exact.
    if A > -1e-9:
        return 0, m - 1
    disc = B * B - A * Cc
    if disc < 0.0:
        return 1, 0
    sq = np.sqrt(disc)
    r1 = (-B - sq) / A
    r2 = (-B + sq) / A
    lo = min(r1, r2)
    hi = max(r1, r2)
    if a + b * 0.5 * (lo + hi) < 0.0:
        return 1, 0
    glo = c0 - 0.5 * h
    ghi = c0 + (m - 0.5) * h
    if hi < glo or lo > ghi:
        return 1, 0
    j0 = int(np.floor((max(lo, glo) - c0) / h + 0.5))
    j1 = int(np.floor((min(hi, ghi) - c0) / h + 0.5))
    return max(0, j0), min(m - 1, j1)


@njit(cache=True, fastmath=True)
def _accumulate_row(r, j0, j1, P, nq, lam, cut, acc):
    """acc[:, q] += Σ_{j0..j1} over one source row block, for every output q of a tile:
    Γ (acc[0:3]) and ∂Γ/∂λ (acc[3:6]). float32 throughout; the inner loop runs over the tile's
    outputs (SoA P). c·p − 1 = −½|c − p|² avoids the cancellation of a float32 dot product."""
    lam = np.float32(lam)
    cut = np.float32(cut)
    hl = _FH * lam
    for j in range(j0, j1 + 1):
        cx = r[CX, j]
        cy = r[CY, j]
        cz = r[CZ, j]
        e0 = r[E0, j]
        e1 = r[E1, j]
        e2 = r[E2, j]
        hs = hl * r[S2, j]
        s2h = _FH * r[S2, j]
        for q in range(nq):
            dx = cx - P[0, q]
            dy = cy - P[1, q]
            dz = cz - P[2, q]
            dd = -_FH * (dx * dx + dy * dy + dz * dz)
            d = dd + _F1
            sn = _F1 - d * d
            # E[e^{λ(v·p−1)}] to second order in an isotropic spread s² of v about c:
            # e^{λ(c·p−1)} · exp(½λs² (½λ(1 − (c·p)²) − c·p))
            w = fast_exp32(lam * dd + hs * (hl * sn - d)) * (dd >= cut)
            # ∂/∂λ of that exponent: (c·p − 1) + ½s²(λ(1 − (c·p)²) − c·p)
            wd = w * (dd + s2h * (lam * sn - d))
            acc[0, q] += e0 * w
            acc[1, q] += e1 * w
            acc[2, q] += e2 * w
            acc[3, q] += e0 * wd
            acc[4, q] += e1 * wd
            acc[5, q] += e2 * wd


@njit(cache=True, fastmath=True, inline="always")
def _poly_tap(cx, cy, cz, px, py, pz, scale, zcut, k1, k2, k3, k4, g0, g1, g2, g3):
    """(w, w·r) of the zonal kernel w = exp(z(k1 + z(k2 + z(k3 + z k4)))), z = scale·(1 − c·p),
    cut at z > zcut, and r = g0 + z(g1 + z(g2 + z g3)) (the λ-derivative over the kernel).
    k1 … k4 come divided by 32 (`exp32_scaled`); the polynomials in Estrin's form (short
    dependency chains)."""
    dx = cx - px
    dy = cy - py
    dz = cz - pz
    z = scale * _FH * (dx * dx + dy * dy + dz * dz)
    z2 = z * z
    w = exp32_scaled(z * ((k1 + z * k2) + z2 * (k3 + z * k4))) * (z <= zcut)
    return w, w * ((g0 + z * g1) + z2 * (g2 + z * g3))


@njit(cache=True, fastmath=True)
def _accumulate_poly(r, j0, j1, P, nq, kern, acc):
    """acc[:, q] += Σ_{j0..j1} E_j (w, w·r)(c_j·p_q) over one source row block with the zonal
    kernel `kern` (see `_poly_tap`); spread-free masses. Four source taps per pass over the
    tile's outputs: independent exp chains keep the vector units busy."""
    scale = np.float32(kern[0])
    zcut = np.float32(kern[1])
    k1, k2, k3, k4 = (np.float32(kern[2] / 32.0), np.float32(kern[3] / 32.0),
                      np.float32(kern[4] / 32.0), np.float32(kern[5] / 32.0))
    g0, g1, g2, g3 = (np.float32(kern[6]), np.float32(kern[7]), np.float32(kern[8]),
                      np.float32(kern[9]))
    for j in range(j0, j1 + 1, 4):
        # the last group is padded with copies of tap j1 at zero energy (a scalar tail would
        # run one exp chain at a time)
        i1 = min(j + 1, j1)
        i2 = min(j + 2, j1)
        i3 = min(j + 3, j1)
        m1 = np.float32(j + 1 <= j1)
        m2 = np.float32(j + 2 <= j1)
        m3 = np.float32(j + 3 <= j1)
        a0, a1, a2, a3 = r[CX, j], r[CX, i1], r[CX, i2], r[CX, i3]
        b0, b1, b2, b3 = r[CY, j], r[CY, i1], r[CY, i2], r[CY, i3]
        c0, c1, c2, c3 = r[CZ, j], r[CZ, i1], r[CZ, i2], r[CZ, i3]
        e00, e01, e02, e03 = r[E0, j], r[E0, i1] * m1, r[E0, i2] * m2, r[E0, i3] * m3
        e10, e11, e12, e13 = r[E1, j], r[E1, i1] * m1, r[E1, i2] * m2, r[E1, i3] * m3
        e20, e21, e22, e23 = r[E2, j], r[E2, i1] * m1, r[E2, i2] * m2, r[E2, i3] * m3
        for q in range(nq):
            px = P[0, q]
            py = P[1, q]
            pz = P[2, q]
            w0, d0 = _poly_tap(a0, b0, c0, px, py, pz, scale, zcut, k1, k2, k3, k4, g0, g1, g2, g3)
            w1, d1 = _poly_tap(a1, b1, c1, px, py, pz, scale, zcut, k1, k2, k3, k4, g0, g1, g2, g3)
            w2, d2 = _poly_tap(a2, b2, c2, px, py, pz, scale, zcut, k1, k2, k3, k4, g0, g1, g2, g3)
            w3, d3 = _poly_tap(a3, b3, c3, px, py, pz, scale, zcut, k1, k2, k3, k4, g0, g1, g2, g3)
            acc[0, q] += e00 * w0 + e01 * w1 + e02 * w2 + e03 * w3
            acc[1, q] += e10 * w0 + e11 * w1 + e12 * w2 + e13 * w3
            acc[2, q] += e20 * w0 + e21 * w1 + e22 * w2 + e23 * w3
            acc[3, q] += e00 * d0 + e01 * d1 + e02 * d2 + e03 * d3
            acc[4, q] += e10 * d0 + e11 * d1 + e12 * d2 + e13 * d3
            acc[5, q] += e20 * d0 + e21 * d1 + e22 * d2 + e23 * d3


@njit(cache=True, parallel=True)
def sg_gather(src, ext, uva, n_out, border, lam, cos_cut, tile, out, kern, h_src, c0):
    """Add Γ(p) = Σ_i E_i e^{λ(c_i·p − 1)} and ∂Γ/∂λ to out[f, i, j, 0:6] at the bordered texel
    centres of a (6, n_out + 2·border, …) cubemap, over the point masses with c_i·p >= cos_cut.

    kern empty: moment-MIP masses (centroid within its texel, spread s²), SG kernel of λ.
    kern (10,): masses exactly at their texel centres with the zonal kernel of `_poly_tap`
    instead (the SG itself, or a chain step's difference kernel; `lam` unused).
    The source grid: m = src.shape[1] rows/columns per face with centres at c0 + i·h_src in
    face coordinates (a map level: h_src = 2/n, c0 = −1 + h_src/2; a chain source extends
    beyond the face and may be subsampled)."""
    spread = kern.shape[0] == 0
    m_src = src.shape[1]
    m = n_out + 2 * border
    nt = (m + tile - 1) // tile
    full = cos_cut <= -1.0 + 1e-12
    for job in prange(6 * nt * nt):
        f = job // (nt * nt)
        ti = (job // nt) % nt
        tj = job % nt
        i_lo = ti * tile
        i_hi = min(m, i_lo + tile)
        j_lo = tj * tile
        j_hi = min(m, j_lo + tile)
        cx, cy, cz = face_dir(uva, f, (0.5 * (j_lo + j_hi) - border) / n_out,
                              (0.5 * (i_lo + i_hi) - border) / n_out)
        cos_t = 1.0
        for a in (i_lo, i_hi - 1):
            for b in (j_lo, j_hi - 1):
                x, y, z = face_dir(uva, f, (b - border + 0.5) / n_out, (a - border + 0.5) / n_out)
                cos_t = min(cos_t, x * cx + y * cy + z * cz)
        # cap of every output, enlarged by a source texel half-diagonal (a centroid lies in its
        # texel), then by the tile radius: the rows/columns scanned for the whole tile
        r_out = np.arccos(max(-1.0, min(1.0, cos_cut))) + (0.75 * h_src if spread else 0.0)
        r_tile = r_out + np.arccos(max(-1.0, min(1.0, cos_t)))
        wide = full or r_tile >= 1.2
        k_tile = np.cos(r_tile)
        s_tile = np.sin(r_tile)
        nq = (i_hi - i_lo) * (j_hi - j_lo)
        P = np.empty((3, nq), np.float32)
        for a in range(i_lo, i_hi):
            for b in range(j_lo, j_hi):
                x, y, z = face_dir(uva, f, (b - border + 0.5) / n_out, (a - border + 0.5) / n_out)
                q = (a - i_lo) * (j_hi - j_lo) + (b - j_lo)
                P[0, q] = x
                P[1, q] = y
                P[2, q] = z
        acc = np.zeros((6, nq), np.float32)
        cut = cos_cut - 1.0
        for g in range(6):
            if wide:
                gi0, gi1 = 0, m_src - 1
            else:
                gi0, gi1 = _tile_rows(uva, g, cx, cy, cz, k_tile, s_tile, h_src, c0, m_src)
            for i in range(gi0, gi1 + 1):
                e_lo = ext[g, i, 0]
                if e_lo < 0:
                    continue
                if wide:
                    j0, j1 = 0, m_src - 1
                else:
                    j0, j1 = _row_interval(uva, g, cx, cy, cz, c0 + i * h_src, k_tile,
                                           h_src, c0, m_src)
                j0 = max(j0, e_lo)
                j1 = min(j1, ext[g, i, 1])
                if j0 > j1:
                    continue
                if spread:
                    _accumulate_row(src[g, i], j0, j1, P, nq, lam, cut, acc)
                else:
                    _accumulate_poly(src[g, i], j0, j1, P, nq, kern, acc)
        for a in range(i_lo, i_hi):
            for b in range(j_lo, j_hi):
                q = (a - i_lo) * (j_hi - j_lo) + (b - j_lo)
                for c in range(6):
                    out[f, a, b, c] += acc[c, q]
    return out
