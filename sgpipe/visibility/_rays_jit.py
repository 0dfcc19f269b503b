"""Compiled ray generation for the per-vertex hemisphere (numpy's (N,3)@(3,3) is ~20× slower)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def fill_rays(local, idx, t, b, n, origin, out_o, out_d):
    """out_d[k] = frame · local[idx[k]] (world), out_o[k] = origin, for k < len(idx);
    idx = None-equivalent is an empty array meaning 'all rows of local'."""
    m = local.shape[0] if idx.shape[0] == 0 else idx.shape[0]
    ox, oy, oz = np.float32(origin[0]), np.float32(origin[1]), np.float32(origin[2])
    tx, ty, tz = np.float32(t[0]), np.float32(t[1]), np.float32(t[2])
    bx, by, bz = np.float32(b[0]), np.float32(b[1]), np.float32(b[2])
    nx, ny, nz = np.float32(n[0]), np.float32(n[1]), np.float32(n[2])
    for k in range(m):
        j = k if idx.shape[0] == 0 else idx[k]
        x, y, z = local[j, 0], local[j, 1], local[j, 2]
        out_d[k, 0] = x * tx + y * bx + z * nx
        out_d[k, 1] = x * ty + y * by + z * ny
        out_d[k, 2] = x * tz + y * bz + z * nz
        out_o[k, 0] = ox
        out_o[k, 1] = oy
        out_o[k, 2] = oz
    return m
