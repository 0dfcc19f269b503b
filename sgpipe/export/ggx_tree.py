"""The split-sum GGX prefilter by hierarchical quadrature over the cube's box MIP tree
(Barnes–Hut style): for a reflected direction r, a tree node is summed as one sample when it
is small against both its distance from r and the lobe width α, else its four children are;
source texels still too large are sub-sampled.

    level(r) = Σ_nodes L̄ Ω ⟨K_α(r·ω)⟩_L / Σ_nodes Ω ⟨K_α(r·ω)⟩_Ω,   K_α = ggx_mapping.ggx_lobe

L̄ is the node's solid-angle mean radiance; ⟨K⟩_L the kernel's mean over the node's light and
⟨K⟩_Ω over its area, each to second order in t = r·ω: K(t̄) + ½ K''(t̄) Var t, from the node's
first and second moments of ω (so a bright lamp inside a coarse node sits where its light is,
and the power-law tail's curvature is carried; a constant map gives a constant level). The
error is set by `accuracy` (node size / max(distance, α)); docs/EXPORT.md gives the measured
errors."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from sgpipe.envmap._cube_jit import FACE_UVA, face_dir

ACCURACY = 0.2          # node size / max(angle to r, α) below which a node is one sample
HORIZON_ALPHA = 0.1     # lobes this broad also resolve the K = 0 horizon (its kink) …
HORIZON_SIZE = 0.04     # … down to nodes of this angular size (radians)
MAX_SUB = 16            # sub-samples per axis of a source texel, at most


@dataclass
class CubeTree:
    """Every box level of a (6, S, S, 3) cube, finest first, flattened: node k of level ℓ is
    offset[ℓ] + (f·n + i)·n + j with n = S >> ℓ."""

    size: int
    offset: np.ndarray        # (levels + 1,) int64
    radiance: np.ndarray      # (nodes, 3): solid-angle mean
    omega: np.ndarray         # (nodes,)
    mean_light: np.ndarray    # (nodes, 3): radiance-weighted mean of ω (not unit)
    mean_area: np.ndarray     # (nodes, 3): solid-angle mean of ω
    cov_light: np.ndarray     # (nodes, 6) float32: covariance of ω (xx yy zz xy xz yz)
    cov_area: np.ndarray      # (nodes, 6) float32


def build_tree(faces: np.ndarray) -> CubeTree:
    """The tree of a cube (6, S, S, 3), S a power of two."""
    faces = np.ascontiguousarray(np.asarray(faces, np.float64)[..., :3])
    s = faces.shape[1]
    if s & (s - 1):
        raise ValueError(f"face size {s} is not a power of two")
    sizes = [s >> k for k in range(s.bit_length())]
    offset = np.concatenate([[0], np.cumsum([6 * n * n for n in sizes])]).astype(np.int64)
    nodes = int(offset[-1])
    t = CubeTree(s, offset, np.empty((nodes, 3)), np.empty(nodes), np.empty((nodes, 3)),
                 np.empty((nodes, 3)), np.empty((nodes, 6), np.float32),
                 np.empty((nodes, 6), np.float32))
    _leaves(faces, t.radiance, t.omega, t.mean_light, t.mean_area, t.cov_light, t.cov_area)
    for lv in range(1, len(sizes)):
        _parents(sizes[lv - 1], offset[lv - 1], offset[lv], t.radiance, t.omega,
                 t.mean_light, t.mean_area, t.cov_light, t.cov_area)
    return t


@njit(cache=True, inline="always")
def _corner(a, b):
    return math.atan2(a * b, math.sqrt(a * a + b * b + 1.0))


@njit(parallel=True, cache=True)
def _leaves(faces, rad, omega, mean_l, mean_a, cov_l, cov_a):
    """Level 0: each texel's radiance, exact solid angle, direction, and its own spread (a
    square of side √Ω in the tangent plane: Ω/12 (I − d dᵀ))."""
    s = faces.shape[1]
    for f in prange(6):
        for i in range(s):
            b0, b1 = 2.0 * i / s - 1.0, 2.0 * (i + 1) / s - 1.0
            for j in range(s):
                a0, a1 = 2.0 * j / s - 1.0, 2.0 * (j + 1) / s - 1.0
                x, y, z = face_dir(FACE_UVA, f, (j + 0.5) / s, (i + 0.5) / s)
                om = _corner(a1, b1) - _corner(a0, b1) - _corner(a1, b0) + _corner(a0, b0)
                k = (f * s + i) * s + j
                omega[k] = om
                for c in range(3):
                    rad[k, c] = faces[f, i, j, c]
                mean_l[k, 0], mean_l[k, 1], mean_l[k, 2] = x, y, z
                mean_a[k, 0], mean_a[k, 1], mean_a[k, 2] = x, y, z
                q = om / 12.0
                cv = (q * (1.0 - x * x), q * (1.0 - y * y), q * (1.0 - z * z),
                      -q * x * y, -q * x * z, -q * y * z)
                for c in range(6):
                    cov_l[k, c] = cv[c]
                    cov_a[k, c] = cv[c]


@njit(cache=True, inline="always")
def _merge(ks, w, mean, cov, out_k, c):
    """Weighted mean and covariance of four children (parallel-axis rule) into node out_k
    (c: a 6-float scratch array)."""
    tot = w[0] + w[1] + w[2] + w[3]
    m0 = m1 = m2 = 0.0
    for n in range(4):
        m0 += w[n] * mean[ks[n], 0]
        m1 += w[n] * mean[ks[n], 1]
        m2 += w[n] * mean[ks[n], 2]
    m0, m1, m2 = m0 / tot, m1 / tot, m2 / tot
    c[:] = 0.0
    for n in range(4):
        k = ks[n]
        d0, d1, d2 = mean[k, 0] - m0, mean[k, 1] - m1, mean[k, 2] - m2
        c[0] += w[n] * (cov[k, 0] + d0 * d0)
        c[1] += w[n] * (cov[k, 1] + d1 * d1)
        c[2] += w[n] * (cov[k, 2] + d2 * d2)
        c[3] += w[n] * (cov[k, 3] + d0 * d1)
        c[4] += w[n] * (cov[k, 4] + d0 * d2)
        c[5] += w[n] * (cov[k, 5] + d1 * d2)
    mean[out_k, 0], mean[out_k, 1], mean[out_k, 2] = m0, m1, m2
    for n in range(6):
        cov[out_k, n] = c[n] / tot


@njit(parallel=True, cache=True)
def _parents(nc, child_off, parent_off, rad, omega, mean_l, mean_a, cov_l, cov_a):
    """Level ℓ from level ℓ − 1 (face size nc): 2×2 sums of power and solid angle, the light-
    and area-weighted means and covariances of the children."""
    n = nc // 2
    for f in prange(6):
        ks = np.empty(4, np.int64)
        wa = np.empty(4)
        wl = np.empty(4)
        scratch = np.empty(6)
        for i in range(n):
            for j in range(n):
                p = parent_off + (f * n + i) * n + j
                for di in range(2):
                    for dj in range(2):
                        k = child_off + (f * nc + 2 * i + di) * nc + 2 * j + dj
                        ks[2 * di + dj] = k
                        wa[2 * di + dj] = omega[k]
                        # a black child still needs a weight: a tiny share of its area's
                        wl[2 * di + dj] = omega[k] * (rad[k, 0] + rad[k, 1] + rad[k, 2]
                                                      + 1e-300)
                om = wa[0] + wa[1] + wa[2] + wa[3]
                omega[p] = om
                for c in range(3):
                    rad[p, c] = (wa[0] * rad[ks[0], c] + wa[1] * rad[ks[1], c]
                                 + wa[2] * rad[ks[2], c] + wa[3] * rad[ks[3], c]) / om
                _merge(ks, wa, mean_a, cov_a, p, scratch)
                _merge(ks, wl, mean_l, cov_l, p, scratch)


@njit(cache=True, inline="always")
def _lobe_mean(rx, ry, rz, m, c, node, a2):
    """⟨K(r·ω)⟩ over a node with mean m and covariance c: K(t̄) + ½ K''(t̄) Var t."""
    t = rx * m[node, 0] + ry * m[node, 1] + rz * m[node, 2]
    var = (rx * rx * c[node, 0] + ry * ry * c[node, 1] + rz * rz * c[node, 2]
           + 2.0 * (rx * ry * c[node, 3] + rx * rz * c[node, 4] + ry * rz * c[node, 5]))
    if t <= 0.0:
        return 0.0
    if var <= 0.0 or t * t < 4.0 * var:          # the kink at t = 0 within reach: plain
        return ggx_kernel(t, a2)
    beta = 0.5 * (a2 - 1.0)
    q = 1.0 + 0.5 * (1.0 + t) * (a2 - 1.0)
    amp = a2 / math.pi
    d0 = amp / (q * q)
    d1 = -2.0 * amp * beta / (q * q * q)
    d2 = 6.0 * amp * beta * beta / (q * q * q * q)
    return d0 * t + 0.5 * (d2 * t + 2.0 * d1) * var


@njit(cache=True, inline="always")
def ggx_kernel(c, a2):
    """K_α(θ) = D_α(cos(θ/2)) max(cos θ, 0) at c = cos θ, a2 = α² (ggx_mapping.ggx_lobe)."""
    if c <= 0.0:
        return 0.0
    ch2 = 0.5 * (1.0 + c)
    den = ch2 * (a2 - 1.0) + 1.0
    return a2 / (math.pi * den * den) * c


@njit(parallel=True, cache=True)
def _prefilter(offset, radiance, omega, mean_light, mean_area, cov_light, cov_area, size, dirs,
               alpha, accuracy, horizon, out):
    levels = len(offset) - 1
    a2 = alpha * alpha
    acc2 = accuracy * accuracy
    hz2 = HORIZON_SIZE * HORIZON_SIZE
    for k in prange(dirs.shape[0]):
        rx, ry, rz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        stack = np.empty((64 * levels + 8, 4), np.int64)
        top = 0
        for f in range(6):
            stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3] = levels - 1, f, 0, 0
            top += 1
        n0 = n1 = n2 = 0.0
        den = 0.0
        while top > 0:
            top -= 1
            lv, f, i, j = stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3]
            n = size >> lv
            node = offset[lv] + (f * n + i) * n + j
            om = omega[node]
            c = rx * mean_area[node, 0] + ry * mean_area[node, 1] + rz * mean_area[node, 2]
            if c < -1.5 * math.sqrt(om):
                continue                                   # wholly behind: K = 0
            d2 = 2.0 * (1.0 - c)                           # chord² ≈ angle² to r
            fine = om <= acc2 * max(d2, a2)
            if horizon and c * c < 2.25 * om and om > hz2:
                fine = False                               # the horizon's kink runs through it
            if fine:
                w = om * _lobe_mean(rx, ry, rz, mean_light, cov_light, node, a2)
                n0 += w * radiance[node, 0]
                n1 += w * radiance[node, 1]
                n2 += w * radiance[node, 2]
                den += om * _lobe_mean(rx, ry, rz, mean_area, cov_area, node, a2)
            elif lv > 0:
                for di in range(2):
                    for dj in range(2):
                        stack[top, 0], stack[top, 1] = lv - 1, f
                        stack[top, 2], stack[top, 3] = 2 * i + di, 2 * j + dj
                        top += 1
            else:                                          # a source texel: sub-sample it
                lim = accuracy * math.sqrt(max(d2, a2))
                ss = min(MAX_SUB, int(math.ceil(math.sqrt(om) / lim)))
                wsum = 0.0
                ksum = 0.0
                for p in range(ss):
                    b = 2.0 * (i + (p + 0.5) / ss) / n - 1.0
                    for q in range(ss):
                        a = 2.0 * (j + (q + 0.5) / ss) / n - 1.0
                        x, y, z = face_dir(FACE_UVA, f, 0.5 * (a + 1.0), 0.5 * (b + 1.0))
                        # sub-texel solid angle ∝ |d|⁻³, |d|² = 1 + a² + b² on the face plane
                        jac = (1.0 + a * a + b * b) ** -1.5
                        wsum += jac
                        ksum += jac * ggx_kernel(rx * x + ry * y + rz * z, a2)
                w = om * ksum / wsum
                n0 += w * radiance[node, 0]
                n1 += w * radiance[node, 1]
                n2 += w * radiance[node, 2]
                den += w
        out[k, 0] = n0 / den
        out[k, 1] = n1 / den
        out[k, 2] = n2 / den


def ggx_tree(tree: CubeTree, dirs: np.ndarray, alpha: float,
             accuracy: float = ACCURACY) -> np.ndarray:
    """The split-sum GGX-α prefilter of the tree's cube at unit directions (M, 3) → (M, 3)."""
    d = np.ascontiguousarray(np.asarray(dirs, np.float64).reshape(-1, 3))
    out = np.empty((len(d), 3))
    _prefilter(tree.offset, tree.radiance, tree.omega, tree.mean_light, tree.mean_area,
               tree.cov_light, tree.cov_area, tree.size, d, float(alpha), float(accuracy),
               alpha >= HORIZON_ALPHA, out)
    return out
