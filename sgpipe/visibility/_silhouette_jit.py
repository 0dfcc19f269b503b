"""Compiled core of the silhouette-guided sampler: which trace texels a visibility boundary
can pass between, and the connected regions of texels it cannot (see silhouette.py)."""

from __future__ import annotations

import numpy as np
from numba import njit

_HALF_PI = 0.5 * np.pi


@njit(cache=True)
def dir_to_texel(x, y, z, t):
    """Unit local direction (z ≥ 0) → continuous (column, row) of a t×t concentric image,
    texel centres at integer + ½ (inverse of hemigrid's Shirley–Chiu map)."""
    s = 1.0 / np.sqrt(1.0 + max(z, 0.0))      # disk radius r = √(1 − z) = ρ / √(1 + z)
    a, b = x * s, y * s
    r = np.sqrt(a * a + b * b)
    if abs(a) >= abs(b):
        sg = 1.0 if a >= 0.0 else -1.0
        u = sg * r
        phi = np.arctan2(sg * b, sg * a)
        v = sg * r * phi * (4.0 / np.pi)
    else:
        sg = 1.0 if b >= 0.0 else -1.0
        phi = np.arctan2(sg * b, sg * a)
        u = sg * r * (_HALF_PI - phi) * (4.0 / np.pi)
        v = sg * r
    return 0.5 * (u + 1.0) * t, 0.5 * (v + 1.0) * t


@njit(cache=True)
def _mark_box(mark, col, row, pad):
    """Mark every texel whose centre lies within `pad` (Chebyshev, texels) of (col, row)."""
    t = mark.shape[0]
    c0 = max(0, int(np.ceil(col - pad - 0.5)))
    c1 = min(t - 1, int(np.floor(col + pad - 0.5)))
    r0 = max(0, int(np.ceil(row - pad - 0.5)))
    r1 = min(t - 1, int(np.floor(row + pad - 0.5)))
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            mark[r, c] = True


@njit(cache=True)
def _mark_arc(mark, a, b, step, pad):
    """Mark the texels near the great-circle arc between local points a and b (z ≥ 0, seen
    from the origin); False when the arc is degenerate (a segment through the origin)."""
    t = mark.shape[0]
    la = np.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    lb = np.sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2])
    if la <= 0.0 or lb <= 0.0:
        return False
    ax, ay, az = a[0] / la, a[1] / la, a[2] / la
    bx, by, bz = b[0] / lb, b[1] / lb, b[2] / lb
    c = ax * bx + ay * by + az * bz
    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    s = np.sqrt(cx * cx + cy * cy + cz * cz)
    if s < 1e-9 and c < 0.0:
        return False
    theta = np.arctan2(s, c)
    wx, wy, wz = bx - c * ax, by - c * ay, bz - c * az
    lw = np.sqrt(wx * wx + wy * wy + wz * wz)
    n = int(np.ceil(theta / step)) + 1
    if lw <= 0.0:
        n = 1
    else:
        wx, wy, wz = wx / lw, wy / lw, wz / lw
    cs, sn = np.cos(theta / n), np.sin(theta / n)
    cp, sp = 1.0, 0.0                                    # cos, sin of the running angle
    for k in range(n + 1):
        if k == n:
            dx, dy, dz = bx, by, bz                      # the far end exactly
        else:
            dx, dy, dz = cp * ax + sp * wx, cp * ay + sp * wy, cp * az + sp * wz
            cp, sp = cp * cs - sp * sn, sp * cs + cp * sn
        col, row = dir_to_texel(dx, dy, dz, t)
        _mark_box(mark, col, row, pad)
    return True


@njit(cache=True)
def silhouette_mark(p0, p1, fa, fb, flip, fn, fd, origin, minv, tol, t, step, pad):
    """(t, t) bool: trace texels within `pad` texels of a projected contour or open edge.

    p0/p1 (E, 3) edge ends, fa/fb (E,) adjacent faces (fb −1 open, −2 non-manifold), flip
    (E,) −1 where the two faces wind the edge the same way, fn (F, 3) unit face normals (0
    when degenerate) and fd (F,) their planes' offsets, origin (3,), minv (3, 3) world →
    local, tol: distance below which the origin counts as in a face's plane (its edges then
    count as contours). Returns (mark, all_marked) — all_marked when an edge passes through
    the origin (no bound holds; the caller traces everything)."""
    mark = np.zeros((t, t), np.bool_)
    nf = fn.shape[0]
    side = np.empty(nf)
    ox, oy, oz = origin[0], origin[1], origin[2]
    for f in range(nf):
        d = fn[f, 0] * ox + fn[f, 1] * oy + fn[f, 2] * oz - fd[f]
        side[f] = 0.0 if abs(d) <= tol else (1.0 if d > 0.0 else -1.0)
    a = np.empty(3)
    b = np.empty(3)
    for e in range(p0.shape[0]):
        if fb[e] >= 0:
            sa, sb = side[fa[e]], side[fb[e]] * flip[e]
            if sa != 0.0 and sa == sb:
                continue                                 # a fold seen from one side only
        for i in range(3):
            a[i] = minv[i, 0] * (p0[e, 0] - ox) + minv[i, 1] * (p0[e, 1] - oy) + \
                minv[i, 2] * (p0[e, 2] - oz)
            b[i] = minv[i, 0] * (p1[e, 0] - ox) + minv[i, 1] * (p1[e, 1] - oy) + \
                minv[i, 2] * (p1[e, 2] - oz)
        if a[2] <= 0.0 and b[2] <= 0.0:
            continue                                     # below the traced hemisphere
        if a[2] < 0.0 or b[2] < 0.0:                     # clip at the tangent plane
            u = a[2] / (a[2] - b[2])
            if a[2] < 0.0:
                for i in range(3):
                    a[i] = a[i] + u * (b[i] - a[i])
                a[2] = 0.0
            else:
                for i in range(3):
                    b[i] = a[i] + u * (b[i] - a[i])
                b[2] = 0.0
        if not _mark_arc(mark, a, b, step, pad):
            mark[:, :] = True
            return mark, True
    return mark, False


@njit(cache=True)
def _find(parent, i):
    """Union–find root with path halving."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True)
def unmarked_regions(mark):
    """4-connected regions of unmarked texels as row runs: (row, c0, c1 exclusive, region id
    per run, number of regions); ids follow the raster order of each region's first texel."""
    t = mark.shape[0]
    cap = t * (t // 2 + 1)
    rr = np.empty(cap, np.int32)
    r0 = np.empty(cap, np.int32)
    r1 = np.empty(cap, np.int32)
    parent = np.empty(cap, np.int64)
    n = 0
    prev_lo = prev_hi = 0                                # runs of the previous row
    for r in range(t):
        lo = n
        c = 0
        while c < t:
            if mark[r, c]:
                c += 1
                continue
            s = c
            while c < t and not mark[r, c]:
                c += 1
            rr[n], r0[n], r1[n], parent[n] = r, s, c, n
            for q in range(prev_lo, prev_hi):            # overlapping runs above join
                if r0[q] < c and s < r1[q]:
                    x, y = _find(parent, q), _find(parent, n)
                    if x < y:
                        parent[y] = x
                    elif y < x:
                        parent[x] = y
            n += 1
        prev_lo, prev_hi = lo, n
    region = np.empty(n, np.int64)
    label = -np.ones(n, np.int64)
    m = 0
    for i in range(n):
        root = _find(parent, i)
        if label[root] < 0:
            label[root] = m
            m += 1
        region[i] = label[root]
    return rr[:n].copy(), r0[:n].copy(), r1[:n].copy(), region, m


@njit(cache=True)
def probe_texels(rr, r0, r1, region, m, t):
    """Three flat texel indices per region (first, middle and last of its texels in raster
    order, repeated when the region is smaller): (m, 3) int64."""
    size = np.zeros(m, np.int64)
    for i in range(rr.shape[0]):
        size[region[i]] += r1[i] - r0[i]
    want = np.empty((m, 3), np.int64)
    for g in range(m):
        want[g, 0], want[g, 1], want[g, 2] = 0, size[g] // 2, size[g] - 1
    out = np.empty((m, 3), np.int64)
    seen = np.zeros(m, np.int64)
    for i in range(rr.shape[0]):
        g = region[i]
        w = r1[i] - r0[i]
        for j in range(3):
            k = want[g, j] - seen[g]
            if 0 <= k < w:
                out[g, j] = rr[i] * t + r0[i] + k
        seen[g] += w
    return out


@njit(cache=True)
def fill_regions(vis, rr, r0, r1, region, value):
    """vis[row, c0:c1] = value[region] for every run (value per region, bool)."""
    for i in range(rr.shape[0]):
        vis[rr[i], r0[i]:r1[i]] = value[region[i]]


@njit(cache=True)
def region_texels(rr, r0, r1, region, which, t):
    """Flat indices of every texel of the regions flagged in `which` (raster order)."""
    n = 0
    for i in range(rr.shape[0]):
        if which[region[i]]:
            n += r1[i] - r0[i]
    out = np.empty(n, np.int64)
    n = 0
    for i in range(rr.shape[0]):
        if which[region[i]]:
            for c in range(r0[i], r1[i]):
                out[n] = rr[i] * t + c
                n += 1
    return out
