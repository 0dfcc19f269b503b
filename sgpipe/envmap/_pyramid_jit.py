"""Compiled cores of the Γ_L pyramid (Wang09 eq 34–35): moment MIP of the source point masses
and the SG gather. Public wrappers live in `pyramid.py`.

Source texels are point masses (energy E = L·Ω, unit centroid c, mean squared spread s² of the
merged masses about c) kept
in a structure-of-arrays row block `src[f, i, k, j]` (face f, row i, component k, column j) so
the inner loop over columns is contiguous and vectorises.
"""
from __future__ import annotations

import math

import numpy as np
from numba import get_thread_id, njit, prange

from sgpipe.envmap._cube_jit import FACE_UVA, face_dir

# component slots of a source row block
CX, CY, CZ, E0, E1, E2, S2 = range(7)
NCOMP = 7
_EXP_MIN = -60.0


@njit(cache=True, parallel=True)
def moment_downsample(src):
    """2×2 merge: summed energies, energy-weighted (channel-sum) unit centroid and mean squared
    spread about it (children's spreads + their offsets), i.e. a moment-preserving MIP."""
    n = src.shape[1] // 2
    out = np.zeros((6, n, NCOMP, n), np.float32)
    for job in prange(6 * n):
        f = job // n
        i = job % n
        for j in range(n):
            wt = 0.0
            c0 = c1 = c2 = 0.0
            g0 = g1 = g2 = 0.0
            for a in range(2):
                for b in range(2):
                    r = src[f, 2 * i + a]
                    jj = 2 * j + b
                    w = abs(r[E0, jj]) + abs(r[E1, jj]) + abs(r[E2, jj])
                    wt += w
                    c0 += w * r[CX, jj]
                    c1 += w * r[CY, jj]
                    c2 += w * r[CZ, jj]
                    g0 += r[CX, jj]
                    g1 += r[CY, jj]
                    g2 += r[CZ, jj]
                    out[f, i, E0, j] += r[E0, jj]
                    out[f, i, E1, j] += r[E1, jj]
                    out[f, i, E2, j] += r[E2, jj]
            if wt <= 0.0:
                c0, c1, c2 = g0, g1, g2
            nn = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
            c0 /= nn
            c1 /= nn
            c2 /= nn
            out[f, i, CX, j] = c0
            out[f, i, CY, j] = c1
            out[f, i, CZ, j] = c2
            s2 = 0.0
            for a in range(2):
                for b in range(2):
                    r = src[f, 2 * i + a]
                    jj = 2 * j + b
                    if wt > 0.0:
                        w = (abs(r[E0, jj]) + abs(r[E1, jj]) + abs(r[E2, jj])) / wt
                    else:
                        w = 0.25
                    dx = r[CX, jj] - c0
                    dy = r[CY, jj] - c1
                    dz = r[CZ, jj] - c2
                    s2 += w * (r[S2, jj] + dx * dx + dy * dy + dz * dz)
            out[f, i, S2, j] = s2
    return out


@njit(cache=True, parallel=True)
def layer_masses(cube, omega, mask, keep, out):
    """Row blocks (6, N, NCOMP, N) float32 of a cubemap's texels as point masses: centres at
    the texel-centre directions (`cube_texel_dirs_jit`), energies L·Ω (Ω = omega (N, N), the
    face's texel solid angles) where mask == keep, else 0, zero spread; and the energy per
    row (6, N, 3) float64 of the texels kept (deterministic: one job per row). `out` (6, N,
    NCOMP, N) float32 comes from the caller (numpy's large allocations are huge-page advised:
    ~10× fewer page faults than an allocation made here)."""
    n = cube.shape[1]
    rows = np.zeros((6, n, 3))
    for job in prange(6 * n):
        f = job // n
        i = job % n
        r0 = r1 = r2 = 0.0
        for j in range(n):
            x, y, z = face_dir(FACE_UVA, f, (j + 0.5) / n, (i + 0.5) / n)
            out[f, i, CX, j] = x
            out[f, i, CY, j] = y
            out[f, i, CZ, j] = z
            if mask[f, i, j] == keep:
                e0 = cube[f, i, j, 0] * omega[i, j]
                e1 = cube[f, i, j, 1] * omega[i, j]
                e2 = cube[f, i, j, 2] * omega[i, j]
                r0 += e0
                r1 += e1
                r2 += e2
            else:
                e0 = e1 = e2 = 0.0
            out[f, i, E0, j] = e0
            out[f, i, E1, j] = e1
            out[f, i, E2, j] = e2
            out[f, i, S2, j] = 0.0
        rows[f, i, 0] = r0
        rows[f, i, 1] = r1
        rows[f, i, 2] = r2
    return out, rows


@njit(cache=True)
def texel_dirs_at(f, i, j, n):
    """Texel-centre directions (k, 3) of the texels (f[k], i[k], j[k]) of an n² cubemap."""
    out = np.empty((f.shape[0], 3))
    for k in range(f.shape[0]):
        x, y, z = face_dir(FACE_UVA, f[k], (j[k] + 0.5) / n, (i[k] + 0.5) / n)
        out[k, 0] = x
        out[k, 1] = y
        out[k, 2] = z
    return out


@njit(cache=True)
def row_extents(src):
    """Per (face, row): first and last column holding energy (−1, −2 when the row is empty)."""
    n = src.shape[1]
    ext = np.empty((6, n, 2), np.int64)
    for f in range(6):
        for i in range(n):
            lo = -1
            hi = -2
            for j in range(n):
                if src[f, i, E0, j] != 0.0 or src[f, i, E1, j] != 0.0 or src[f, i, E2, j] != 0.0:
                    if lo < 0:
                        lo = j
                    hi = j
            ext[f, i, 0] = lo
            ext[f, i, 1] = hi
    return ext


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
    # per-tap test in `_accumulate` keeps the sum exact.
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


_F0 = np.float32(0.0)
_F1 = np.float32(1.0)
_FH = np.float32(0.5)
_FMIN = np.float32(_EXP_MIN)
_F64TH = np.float32(0.015625)
_FC = tuple(np.float32(1.0 / math.factorial(k)) for k in range(11))


@njit(cache=True, fastmath=True, inline="always")
def fast_exp32(x):
    """e^x for x in [−60, 0] (clamped), float32 (8 lanes per AVX2 register): degree-10 Taylor
    of e^{x/64}, squared six times. Relative error < 1e-5 (float32 rounding, amplified by the
    squarings; Horner's form: Estrin's, as in `exp32_scaled`, rounds to 1.3e-5); branch-free
    so the gather loop vectorises."""
    x = min(max(x, _FMIN), _F0) * _F64TH
    y = _FC[0] + x * (_FC[1] + x * (_FC[2] + x * (_FC[3] + x * (_FC[4] + x * (
        _FC[5] + x * (_FC[6] + x * (_FC[7] + x * (_FC[8] + x * (_FC[9] + x * _FC[10])))))))))
    y = y * y
    y = y * y
    y = y * y
    y = y * y
    y = y * y
    return y * y


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


_FM1 = np.float32(-1.0)


@njit(cache=True, fastmath=True, inline="always")
def exp32_scaled(y):
    """e^{32y} for y in [−1, 0] (clamped below), float32: degree-7 Taylor of e^y in Estrin's
    form (powers y², y⁴ beside the pairs: the rows' inner loops are bound by the latency of one
    lane's chain, not by their operation count, and Estrin's chain is half as long as
    Horner's), squared five times. Relative error ≤ 5e-6 for 32y ≥ −12 (float32
    rounding, as `fast_exp32`), 2.5e-4 at −25, 2e-3 at −32 (weights ≤ 1e-10 there). Callers fold
    the 1/32 into the coefficients of the exponent's polynomial (one multiplication less on
    the chain)."""
    x = max(y, _FM1)
    x2 = x * x
    x4 = x2 * x2
    r = (((_FC[0] + x * _FC[1]) + x2 * (_FC[2] + x * _FC[3]))
         + x4 * ((_FC[4] + x * _FC[5]) + x2 * (_FC[6] + x * _FC[7])))
    r = r * r
    r = r * r
    r = r * r
    r = r * r
    return r * r


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


_Z = math.sqrt(3.0) - 2.0          # pole of the cubic B-spline prefilter


@njit(cache=True, parallel=True)
def finish_level(acc, lam, norm, extra, values, slopes, plain, scratch):
    """From the gathered Γ, ∂Γ/∂λ (6, m, m, 6): V = Γ/S(λ), m = λ Γ'/Γ, then cubic B-spline
    coefficients per face and channel (rows, then columns), cropped by `extra` into the
    (6·w, w, 3) float32 images `values` and `slopes` (w = m − 2·extra); `plain` (6·(w−2), w−2, 3)
    receives the V samples themselves with a 1-texel border. One job per face and quantity,
    three channels at once (the accumulator is read twice, the images written contiguously);
    each thread works in its own row of `scratch` (float64, ≥ 3·m² per thread: the caller's,
    reused from level to level)."""
    m = acc.shape[1]
    w = m - 2 * extra
    wp = w - 2
    for job in prange(12):
        f = job // 2
        slope = job % 2 == 1
        buf = scratch[get_thread_id(), :3 * m * m].reshape((m, 3 * m))
        for i in range(m):
            for j in range(m):
                for c in range(3):
                    g = acc[f, i, j, c]
                    if slope:
                        buf[i, 3 * j + c] = lam * acc[f, i, j, c + 3] / g if g > 0.0 else 0.0
                    else:
                        buf[i, 3 * j + c] = g / norm
        if not slope:
            for i in range(wp):
                for j in range(wp):
                    for c in range(3):
                        plain[f * wp + i, j, c] = buf[i + extra + 1, 3 * (j + extra + 1) + c]
        _prefilter_rows(buf)                # along i (vectorised over j and the channels)
        _prefilter_interleaved(buf, 3)      # along j, row by row (a transpose costs more)
        img = slopes if slope else values
        for i in range(extra, m - extra):
            for j in range(extra, m - extra):
                for c in range(3):
                    img[f * w + i - extra, j - extra, c] = buf[i, 3 * j + c]


@njit(cache=True)
def _prefilter_rows(b):
    """In-place cubic B-spline interpolation prefilter (mirror boundary, Unser: gain 6, causal
    and anti-causal recursions with pole z = √3 − 2) along axis 0 of b (m, k), for all k columns
    at once so the inner loops run over contiguous rows."""
    z = _Z
    n, k_cols = b.shape
    horizon = min(n, 30)
    s = np.zeros(k_cols)
    zk = 1.0
    for k in range(horizon):
        for j in range(k_cols):
            s[j] += zk * b[k, j]
        zk *= z
    for j in range(k_cols):
        b[0, j] = 6.0 * s[j]
    for k in range(1, n):
        for j in range(k_cols):
            b[k, j] = 6.0 * b[k, j] + z * b[k - 1, j]
    c = z / (z * z - 1.0)
    for j in range(k_cols):
        b[n - 1, j] = c * (b[n - 1, j] + z * b[n - 2, j])
    for k in range(n - 2, -1, -1):
        for j in range(k_cols):
            b[k, j] = z * (b[k + 1, j] - b[k, j])


@njit(cache=True)
def _prefilter_interleaved(b, nc):
    """`_prefilter_rows` along axis 1 of b (r, m·nc) holding m samples of nc interleaved
    channels per row: the same recursions, one row at a time."""
    z = _Z
    r = b.shape[0]
    n = b.shape[1] // nc
    horizon = min(n, 30)
    c_end = z / (z * z - 1.0)
    for i in range(r):
        row = b[i]
        for c in range(nc):
            s = 0.0
            zk = 1.0
            for k in range(horizon):
                s += zk * row[k * nc + c]
                zk *= z
            row[c] = 6.0 * s
        for k in range(1, n):
            for c in range(nc):
                row[k * nc + c] = 6.0 * row[k * nc + c] + z * row[(k - 1) * nc + c]
        for c in range(nc):
            row[(n - 1) * nc + c] = c_end * (row[(n - 1) * nc + c] + z * row[(n - 2) * nc + c])
        for k in range(n - 2, -1, -1):
            for c in range(nc):
                row[k * nc + c] = z * (row[(k + 1) * nc + c] - row[k * nc + c])


@njit(cache=True, inline="always")
def _step5(y):
    """C⁵ step 0 → 1 on [0, 1] with S(y) + S(1 − y) = 1 (S' ∝ y⁵(1 − y)⁵)."""
    y = min(max(y, 0.0), 1.0)
    return y ** 6 * (462.0 + y * (-1980.0 + y * (3465.0 + y * (-3080.0 + y * (
        1386.0 - 252.0 * y)))))


def chain_source_shape(n, pad, step):
    """Shape of `chain_source`'s row blocks."""
    m = (n + 2 * pad + step - 1) // step
    return (6, m, NCOMP, m)


@njit(cache=True, parallel=True)
def chain_source(acc, n, ext, norm, pad, blend, uva, step, out):
    """Masses of a level's V = acc[..., 0:3]/norm at every `step`-th of its texel centres
    extended `pad` texels beyond each face (row blocks (6, m, NCOMP, m), m = ⌈(n + 2·pad)/step⌉,
    centres at c0 + i·step·h, c0 = −1 + (½ − pad)·h, h = 2/n), weighted for the quadrature
    of smooth integrands over S²: the midpoint rule in face coordinates (J·h²) times the face's
    share φ_f of a smooth partition of unity (C⁵ steps of half-width `blend` texels across every
    face edge, normalised over the faces), into `out` (zeros, `chain_source_shape`). See
    pyramid._chain_source."""
    m = (n + 2 * pad + step - 1) // step
    h = 2.0 / n
    d = 2.0 * blend * h
    hh = (step * h) ** 2 / norm
    for job in prange(6 * m):
        f = job // m
        i = job % m
        t = (step * i - pad + 0.5) * h - 1.0
        for j in range(m):
            s = (step * j - pad + 0.5) * h - 1.0
            x = s * uva[f, 0, 0] + t * uva[f, 1, 0] + uva[f, 2, 0]
            y = s * uva[f, 0, 1] + t * uva[f, 1, 1] + uva[f, 2, 1]
            z = s * uva[f, 0, 2] + t * uva[f, 1, 2] + uva[f, 2, 2]
            q = x * x + y * y + z * z           # = 1 + s² + t² (an orthonormal frame)
            ir = 1.0 / np.sqrt(q)
            x *= ir
            y *= ir
            z *= ir
            total = 1.0
            own = 1.0
            if abs(s) > 1.0 - 0.5 * d or abs(t) > 1.0 - 0.5 * d:    # in a blend: φ_f < 1
                total = 0.0
                own = 0.0
            for g in range(6 if total == 0.0 else 0):
                a = x * uva[g, 2, 0] + y * uva[g, 2, 1] + z * uva[g, 2, 2]
                if a <= 1e-9:
                    continue
                sg = (x * uva[g, 0, 0] + y * uva[g, 0, 1] + z * uva[g, 0, 2]) / a
                tg = (x * uva[g, 1, 0] + y * uva[g, 1, 1] + z * uva[g, 1, 2]) / a
                ps = (_step5((1.0 + 0.5 * d - abs(sg)) / d)
                      * _step5((1.0 + 0.5 * d - abs(tg)) / d))
                total += ps
                if g == f:
                    own = ps
            w = own / total * (ir * ir * ir) * hh if total > 0 else 0.0
            out[f, i, CX, j] = x
            out[f, i, CY, j] = y
            out[f, i, CZ, j] = z
            for c in range(3):
                out[f, i, E0 + c, j] = acc[f, ext - pad + step * i, ext - pad + step * j, c] * w
    return out
