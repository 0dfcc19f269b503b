"""Compiled core of the exact spherical nearest-boundary search (Wang09 eq 23).

Branch and bound on spherical caps: boundary points are bucketed by trace-image tile (each
tile has a fixed bounding cap), query texels are grouped in blocks (each with a bounding
cap). A block keeps only the tiles that can hold the nearest point of one of its texels;
each texel then scans those tiles' points exhaustively. The result is the exact minimum
angle over all boundary points (no approximation), in cosine space without per-pair trig.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _cos_add(ca, sa, cb, sb):
    """cos(a + b) from cosines/sines, saturating at −1 once a + b ≥ π."""
    c = ca * cb - sa * sb
    s = sa * cb + ca * sb
    if s < 0.0:          # a + b > π
        return -1.0
    return c


@njit(cache=True)
def nearest_boundary_angle(q, bound, block, bcen, bcos, bsin, pts, start, tcen, tcos, tsin):
    """min(bound, exact min angle from each query direction q (R, R, 3) to the points `pts`).

    bound: (R, R) angles beyond which the distance is not needed (they prune the search);
    block: query block size; bcen/bcos/bsin: (nb, nb, 3)/(nb, nb) block caps; start: CSR
    offsets of pts per tile; tcen/tcos/tsin: tile caps. Returns (R, R) angles.
    """
    res = q.shape[0]
    nb = bcen.shape[0]
    ntile = tcen.shape[0]
    out = bound.copy()
    live = np.empty(ntile, np.int64)
    nlive = 0
    for k in range(ntile):
        if start[k + 1] > start[k]:
            live[nlive] = k
            nlive += 1
    if nlive == 0:
        return out
    cand = np.empty(nlive, np.int64)
    ordered = np.empty(nlive, np.int64)
    cosbk = np.empty(nlive)
    for bi in range(nb):
        for bj in range(nb):
            cx, cy, cz = bcen[bi, bj, 0], bcen[bi, bj, 1], bcen[bi, bj, 2]
            # Upper bound U on the distance of every texel of the block: min_K ∠(c,c_K)+r_K+r_B.
            best_cos = -1.0
            for j in range(nlive):
                k = live[j]
                cbk = cx * tcen[k, 0] + cy * tcen[k, 1] + cz * tcen[k, 2]
                cbk = min(1.0, max(-1.0, cbk))
                cosbk[j] = cbk
                u = _cos_add(cbk, np.sqrt(1.0 - cbk * cbk), tcos[k], tsin[k])
                if u > best_cos:
                    best_cos = u
            # ... capped by the largest distance any texel of the block still needs
            r0 = bi * block
            c0 = bj * block
            bmax = 0.0
            for r in range(r0, min(r0 + block, res)):
                for c in range(c0, min(c0 + block, res)):
                    bmax = max(bmax, bound[r, c])
            best_cos = max(best_cos, np.cos(min(bmax, np.pi)))
            cu = _cos_add(best_cos, np.sqrt(max(0.0, 1.0 - best_cos * best_cos)),
                          bcos[bi, bj], bsin[bi, bj])
            # U' = U + r_B (the candidate radius about the block centre, before + r_K).
            su = np.sqrt(max(0.0, 1.0 - cu * cu))
            cu2 = _cos_add(cu, su, bcos[bi, bj], bsin[bi, bj])
            su2 = np.sqrt(max(0.0, 1.0 - cu2 * cu2))
            if cu <= -1.0:
                cu2, su2 = -1.0, 0.0
            nc = 0
            for j in range(nlive):
                k = live[j]
                lim = _cos_add(cu2, su2, tcos[k], tsin[k]) if cu2 > -1.0 else -1.0
                if cosbk[j] >= lim - 1e-12:
                    cand[nc] = j
                    nc += 1
            # nearest tiles first, so that the per-texel bound below prunes early
            order = np.argsort(-cosbk[cand[:nc]])
            for j in range(nc):
                ordered[j] = live[cand[order[j]]]
            for r in range(r0, min(r0 + block, res)):
                for c in range(c0, min(c0 + block, res)):
                    qx, qy, qz = q[r, c, 0], q[r, c, 1], q[r, c, 2]
                    b0 = min(bound[r, c], np.pi)
                    best = np.cos(b0)
                    sbest = np.sin(b0)
                    for j in range(nc):
                        k = ordered[j]
                        # skip the tile if ∠(q, c_K) − r_K > current best angle
                        qk = qx * tcen[k, 0] + qy * tcen[k, 1] + qz * tcen[k, 2]
                        if qk < _cos_add(best, sbest, tcos[k], tsin[k]) - 1e-12:
                            continue
                        for p in range(start[k], start[k + 1]):
                            d = qx * pts[p, 0] + qy * pts[p, 1] + qz * pts[p, 2]
                            if d > best:
                                best = d
                        best = min(1.0, best)
                        sbest = np.sqrt(max(0.0, 1.0 - best * best))
                    out[r, c] = np.arccos(min(1.0, max(-1.0, best)))
    return out


@njit(cache=True)
def point_caps(pts, start, tcen, tcos, tsin):
    """Bounding caps of each tile's points (CSR `start`), where tighter than the tile's own
    cap (tcen/tcos/tsin): centre = normalised mean, radius = largest angle, inflated like
    the static caps. Empty tiles keep their cap (never visited)."""
    n = start.shape[0] - 1
    cen = tcen.copy()
    cs = tcos.copy()
    sn = tsin.copy()
    for k in range(n):
        if start[k + 1] <= start[k]:
            continue
        x = y = z = 0.0
        for p in range(start[k], start[k + 1]):
            x += pts[p, 0]
            y += pts[p, 1]
            z += pts[p, 2]
        ln = np.sqrt(x * x + y * y + z * z)
        if ln <= 1e-9:
            continue
        x, y, z = x / ln, y / ln, z / ln
        lo = 1.0
        for p in range(start[k], start[k + 1]):
            lo = min(lo, x * pts[p, 0] + y * pts[p, 1] + z * pts[p, 2])
        r = np.arccos(min(1.0, max(-1.0, lo))) * (1.0 + 1e-9) + 1e-12
        if np.cos(r) > tcos[k]:
            cen[k, 0], cen[k, 1], cen[k, 2] = x, y, z
            cs[k] = np.cos(r)
            sn[k] = np.sin(r)
    return cen, cs, sn


@njit(cache=True)
def block_fraction(vis, res):
    """(T, T) bool → (R, R) float32 mean over k×k blocks (k = T/R)."""
    k = vis.shape[0] // res
    out = np.empty((res, res), np.float32)
    inv = 1.0 / (k * k)
    for i in range(res):
        for j in range(res):
            n = 0
            for a in range(i * k, i * k + k):
                for b in range(j * k, j * k + k):
                    n += vis[a, b]
            out[i, j] = n * inv
    return out


@njit(cache=True)
def block_fraction_words(words, res):
    """block_fraction of a (T, T) 0/1 byte image viewed as (T, T/4) uint32 (k a multiple of
    4): four texels are summed per word (bytes ≤ 1: byte 3 of x·0x01010101 is their sum)."""
    t = words.shape[0]
    k = t // res
    kw = k // 4
    out = np.empty((res, res), np.float32)
    inv = 1.0 / (k * k)
    for i in range(res):
        for j in range(res):
            n = 0
            for a in range(i * k, i * k + k):
                for b in range(j * kw, j * kw + kw):
                    n += ((words[a, b] * 0x01010101) >> 24) & 0xFF
            out[i, j] = n * inv
    return out


@njit(cache=True)
def _uniform_h(words, r, w, nw):
    """True when the 8 texels of word w of row r and the first texel of the next word are
    all equal (bytes are 0/1, little-endian: texel 8w + j is byte j)."""
    x = words[r, w]
    if ((x ^ (x >> np.uint64(8))) & np.uint64(0x00FFFFFFFFFFFFFF)) != 0:
        return False
    if w + 1 < nw:
        return ((x >> np.uint64(56)) ^ (words[r, w + 1] & np.uint64(0xFF))) == 0
    return True


@njit(cache=True)
def boundary_by_tile(vis, words, mid_h, mid_v, tile):
    """Midpoints of 4-neighbour pairs of different visibility, bucketed by the trace tile of
    their first texel: (points (M, 3) sorted by tile, CSR offsets (n_tiles + 1,)). `words`
    is vis viewed as uint64 (t a multiple of 8): uniform runs of 8 texels are skipped."""
    t = vis.shape[0]
    nw = words.shape[1]
    nt = (t + tile - 1) // tile
    cap = 2 * t * t
    rr = np.empty(cap, np.int32)
    cc = np.empty(cap, np.int32)
    m = 0
    for r in range(t):
        for w in range(nw):
            if _uniform_h(words, r, w, nw):
                continue
            for c in range(8 * w, min(8 * w + 8, t - 1)):
                if vis[r, c] != vis[r, c + 1]:
                    rr[m] = r
                    cc[m] = c
                    m += 1
    mh = m
    for r in range(t - 1):
        for w in range(nw):
            if words[r, w] == words[r + 1, w]:
                continue
            for c in range(8 * w, min(8 * w + 8, t)):
                if vis[r, c] != vis[r + 1, c]:
                    rr[m] = r
                    cc[m] = c
                    m += 1
    start = np.zeros(nt * nt + 1, np.int64)
    for i in range(m):
        start[(rr[i] // tile) * nt + cc[i] // tile + 1] += 1
    for k in range(nt * nt):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    pts = np.empty((m, 3))
    for i in range(m):
        k = (rr[i] // tile) * nt + cc[i] // tile
        src = mid_h if i < mh else mid_v
        pts[fill[k], 0] = src[rr[i], cc[i], 0]
        pts[fill[k], 1] = src[rr[i], cc[i], 1]
        pts[fill[k], 2] = src[rr[i], cc[i], 2]
        fill[k] += 1
    return pts, start
