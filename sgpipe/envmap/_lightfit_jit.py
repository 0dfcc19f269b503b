"""Compiled texel sums for the light fits (numba cores behind `sgpipe.envmap.lightfit`).

Texel data come as (3, M) rows (directions dT, masses eT = L Ω per channel) so the inner loops
vectorise; each output row is one sum over the texels whose order does not depend on the
thread count, so the results are deterministic."""
from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, fastmath=True, inline="always")
def _exp_nonpos(x):
    """e^x for x <= 0 without a libm call (vectorisable): (e^{x/256})^{256}, the inner factor by
    its degree-10 Taylor polynomial; rel. error < 4e-14 on [−32, 0], < 2e-12 on [−64, 0]."""
    y = x * 0.00390625
    p = 1.0 / 3628800.0
    p = p * y + 1.0 / 362880.0
    p = p * y + 1.0 / 40320.0
    p = p * y + 1.0 / 5040.0
    p = p * y + 1.0 / 720.0
    p = p * y + 1.0 / 120.0
    p = p * y + 1.0 / 24.0
    p = p * y + 1.0 / 6.0
    p = p * y + 0.5
    p = p * y + 1.0
    p = p * y + 1.0
    for _ in range(8):
        p = p * p
    return p


@njit(cache=True, parallel=True, fastmath=True)
def _zonal_sums(q, dT, eT, lam, clamped_cos):
    """out_i = Σ_j k(q_i·d_j) e_j with k(c) = max(0, c) (clamped_cos) or e^{λ(c − 1)}; the
    kernel choice is loop-invariant, so the compiler unswitches the loop and both vectorise."""
    m = dT.shape[1]
    out = np.empty((q.shape[0], 3))
    for i in prange(q.shape[0]):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        qx = q[i, 0]
        qy = q[i, 1]
        qz = q[i, 2]
        for j in range(m):
            c = qx * dT[0, j] + qy * dT[1, j] + qz * dT[2, j]
            if clamped_cos:
                w = max(c, 0.0)
            else:
                w = _exp_nonpos(min(lam * (c - 1.0), 0.0))
            a0 += w * eT[0, j]
            a1 += w * eT[1, j]
            a2 += w * eT[2, j]
        out[i, 0] = a0
        out[i, 1] = a1
        out[i, 2] = a2
    return out


@njit(cache=True)
def sg_blur_sums(q, dT, eT, lam):
    """out_i = Σ_j e^{λ(q_i·d_j − 1)} e_j (Wang09 eq 2 kernel over texel masses), λ <= 32."""
    return _zonal_sums(q, dT, eT, lam, False)


@njit(cache=True)
def clamped_cos_sums(n, dT, eT):
    """out_i = Σ_j max(0, n_i·d_j) e_j: the texel quadrature of E(n) = ∫ L max(0, n·ω) dω."""
    return _zonal_sums(n, dT, eT, 0.0, True)


@njit(cache=True, parallel=True)
def ring_clamped_cos_sums(cn, ct, st, g):
    """out_i = Σ_j g_j H(cn_i ct_j, sn_i st_j), sn = √(1 − cn²), with the azimuthal integral
    H(a, b) = ∫_0^{2π} max(0, a + b cos φ) dφ = 2(a φ₀ + √(b² − a²)), φ₀ = acos(−a/b)
    (2πa when a >= b, 0 when a <= −b): an SG's irradiance from nodes in cos θ about its axis."""
    out = np.empty(cn.shape[0])
    for i in prange(cn.shape[0]):
        sn = np.sqrt(max(1.0 - cn[i] * cn[i], 0.0))
        acc = 0.0
        for j in range(ct.shape[0]):
            a = cn[i] * ct[j]
            b = sn * st[j]
            if a >= b:
                acc += g[j] * 2.0 * np.pi * a
            elif a > -b:
                acc += g[j] * 2.0 * (a * np.arccos(-a / b) + np.sqrt(b * b - a * a))
        out[i] = acc
    return out


@njit(cache=True)
def blurred_lobes(q, axes, lam, lam_b, s_b):
    """v_qk = ⟨G(·; p_k, λ_k, 1), G(·; q, λ_b, 1)⟩ / S(λ_b) (Wang09 eq 4) with d_qk = ‖λ_k p_k +
    λ_b q‖ and q·p_k, all (Q, K); d is written without cancellation near q = −p."""
    nq, k = q.shape[0], axes.shape[0]
    v = np.empty((nq, k))
    qp = np.empty((nq, k))
    dd = np.empty((nq, k))
    for i in range(nq):
        for j in range(k):
            c = q[i, 0] * axes[j, 0] + q[i, 1] * axes[j, 1] + q[i, 2] * axes[j, 2]
            d = np.sqrt((lam[j] - lam_b) ** 2 + 2.0 * lam_b * lam[j] * (1.0 + c))
            d = max(d, 1e-12)
            qp[i, j] = c
            dd[i, j] = d
            v[i, j] = 2.0 * np.pi * np.exp(d - lam[j] - lam_b) * (-np.expm1(-2.0 * d)) / (d * s_b)
    return v, qp, dd


@njit(cache=True, fastmath=True)
def gauss_newton_blocks(q, w, r, axes, lam, e1, e2, lam_b, v, qp, dd):
    """Columns B = [∂v/∂δ₁, ∂v/∂δ₂, ∂v/∂ln λ, v] (Q, 4K) of the blurred lobes (tangent steps
    p + δ₁e₁ + δ₂e₂) → (G = Bᵀ diag(w) B, Bᵀ diag(w) r). ∂d/∂p = λ(I − ppᵀ)a/d, a = λp + λ_b q,
    ∂ ln(sinh d / d)/∂d = coth d − 1/d."""
    nq, k = q.shape[0], axes.shape[0]
    bt = np.empty((4 * k, nq))
    for i in range(nq):
        for j in range(k):
            d = dd[i, j]
            if d < 1e-3:
                g = d / 3.0
            else:
                g = 1.0 / np.tanh(d) - 1.0 / d
            f = v[i, j] * g * lam[j] * lam_b / d
            bt[j, i] = f * (q[i, 0] * e1[j, 0] + q[i, 1] * e1[j, 1] + q[i, 2] * e1[j, 2])
            bt[k + j, i] = f * (q[i, 0] * e2[j, 0] + q[i, 1] * e2[j, 1] + q[i, 2] * e2[j, 2])
            bt[2 * k + j, i] = lam[j] * v[i, j] * (g * (lam[j] + lam_b * qp[i, j]) / d - 1.0)
            bt[3 * k + j, i] = v[i, j]
    m = 4 * k
    wb = np.empty((m, nq))
    for a in range(m):
        for i in range(nq):
            wb[a, i] = w[i] * bt[a, i]
    gram = np.empty((m, m))
    rhs = np.zeros((m, 3))
    for a in range(m):
        for b in range(a + 1):
            acc = 0.0
            for i in range(nq):
                acc += wb[a, i] * bt[b, i]
            gram[a, b] = acc
            gram[b, a] = acc
        for c in range(3):
            acc = 0.0
            for i in range(nq):
                acc += wb[a, i] * r[i, c]
            rhs[a, c] = acc
    return gram, rhs
