"""Compiled cores of the Γ_L pyramid's point masses (Wang09 eq 34): the map's texels as masses
and their moment-preserving MIP.

A mass has an energy E = L·Ω, a unit centroid c and the mean squared spread s² of the merged
masses about c; masses are kept in a structure-of-arrays row block `src[f, i, k, j]` (face f,
row i, component k, column j) so the inner loops over columns are contiguous and vectorise.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from sgpipe.envmap._cube_jit import FACE_UVA, face_dir

# component slots of a source row block
CX, CY, CZ, E0, E1, E2, S2 = range(7)
NCOMP = 7


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
    the texel-centre directions (`_cube_jit.cube_texel_dirs_jit`), energies L·Ω (Ω = omega
    (N, N), the face's texel solid angles) where mask == keep, else 0, zero spread; and the
    energy per row (6, N, 3) float64 of the texels kept (deterministic: one job per row).
    `out` (6, N, NCOMP, N) float32 comes from the caller (numpy's large allocations are
    huge-page advised: far fewer page faults than an allocation made here)."""
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
