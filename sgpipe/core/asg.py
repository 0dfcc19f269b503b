"""Anisotropic spherical Gaussians (Xu, Sun, Liu, Tong, Wang 2013, "Anisotropic Spherical
Gaussians", eq 4): G(v; [x, y, z], [λ, μ], c) = c · max(v·z, 0) · e^{−λ(v·x)² − μ(v·y)²}, their
integral, and their warp from half-vector space to light space as a set of isotropic SG
sub-lobes ("1 ASG ≈ many SGs"), the numpy mirror of kernels/include/asg.h.

Frames: z the lobe axis, x the axis of sharpness λ, y = z × x the axis of sharpness μ.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import erf

from sgpipe.core.quadrature import gauss_legendre

#: Sub-lobe spacing along the broad axis in units of the sub-lobe's σ: a sum of Gaussians of
#: width σ spaced Δ apart ripples by ≈ 2e^{−2π²σ²/Δ²} (0.3 % at Δ = 1.75σ).
SPACING_SIGMAS = 1.75
#: ... and never below 1/2 of the spacing once the nodes are capped (ripple ≈ 1.4 %).
FLOOR_SIGMAS = 2.0
#: The sub-lobes span ±RANGE_SIGMAS standard deviations of the broad axis (weights renormalised).
RANGE_SIGMAS = 3.0
#: The kernel's sparser set (asg.h ASG_SPACING, ASG_RANGE): spacing 2 σ (ripple ≤ 1.4 % against a
#: point, averaged out by any source wider than σ; 12 % fewer Γ_L lookups on long chains) over
#: the same ±3 σ (a sun in the tails of a rough GGX lobe needs them).
KERNEL_SPACING_SIGMAS = 2.0
KERNEL_RANGE_SIGMAS = RANGE_SIGMAS
#: ... and beyond 2 σ of the line (weights ≤ e^{−2} of the centre's) neighbouring nodes merge in
#: pairs by exact moments (asg.h ASG_MERGE_FROM): about a sixth fewer Γ_L lookups again.
KERNEL_MERGE_FROM = 2.0
#: Default cap on sub-lobes per side (kernel define ASG_MAX_HALF): beyond it the sub-lobes widen.
MAX_HALF = 32


def asg_eval(v, z, x, lam, mu, c=1.0):
    """Xu13 eq 4: c · max(v·z, 0) · exp(−λ(v·x)² − μ(v·y)²), y = z × x; v (..., 3)."""
    v = np.asarray(v, float)
    z, x = np.asarray(z, float), np.asarray(x, float)
    y = np.cross(z, x)
    s = np.maximum(v @ z, 0.0)
    return c * s * np.exp(-lam * (v @ x) ** 2 - mu * (v @ y) ** 2)


def _z_erf(a):
    """Z(a) = ∫_{−1}^{1} e^{−a u²} du = √(π/a) erf(√a)."""
    a = np.asarray(a, float)
    sa = np.sqrt(np.maximum(a, 1e-300))
    return np.where(a < 1e-8, 2.0 - 2.0 * a / 3.0, np.sqrt(np.pi) * erf(sa) / sa)


def asg_integral(lam, mu, c=1.0, n: int = 96) -> float:
    """∫_{S²} G exactly: the S factor (v·z) dω is the area element of the disk the upper
    hemisphere projects to, so ∫ G = c ∫_{x²+y²≤1} e^{−λx² − μy²} dx dy (Xu13's normalisation
    π/√(λμ) is its sharp limit); evaluated as c ∫ e^{−μy²} √(π/λ) erf(√(λ(1−y²))) dy with
    Gauss–Legendre panels graded around y = 0."""
    w = min(1.0, 8.0 / np.sqrt(2.0 * max(mu, 1e-12)))
    nodes, weights = [], []
    for a, b in ((-1.0, -w), (-w, w), (w, 1.0)):
        if b > a:
            xx, ww = gauss_legendre(n, a, b)
            nodes.append(xx)
            weights.append(ww)
    y, wy = np.concatenate(nodes), np.concatenate(weights)
    r = np.sqrt(np.maximum(1.0 - y * y, 0.0))
    inner = r * _z_erf(lam * r * r)            # ∫_{−r}^{r} e^{−λx²} dx
    return float(c * np.sum(wy * np.exp(-mu * y * y) * inner))


def asg_mass(lam, mu, c=1.0):
    """c·Z(λ)·Z(μ): the integral over the square [−1, 1]² ⊃ disk, what the kernel uses (its
    excess over asg_integral is below e^{−min(λ, μ)})."""
    return c * _z_erf(lam) * _z_erf(mu)


def _perp_basis(o, h, fallback):
    """(e_par, e_perp) at h: e_perp ⊥ the plane of incidence (o, h), e_par = e_perp × h."""
    ep = np.cross(o, h)
    n = np.linalg.norm(ep)
    if n < 1e-7:
        ep = fallback - np.dot(fallback, h) * h
        n = np.linalg.norm(ep)
    ep = ep / n
    return np.cross(ep, h), ep


def _warped_cov(o, h, x, lam, mu):
    """2×2 covariance, in the i-space basis (e'_par, e_perp), of the ASG's local Gaussian at h
    mapped by the half-vector Jacobian: in the plane of incidence ×2, across it ×2(o·h)."""
    og = float(np.dot(o, h))
    xk = x - np.dot(x, h) * h
    xk /= np.linalg.norm(xk)
    yk = np.cross(h, xk)
    e_par, e_perp = _perp_basis(o, h, xk)
    R = np.array([[xk @ e_par, yk @ e_par], [xk @ e_perp, yk @ e_perp]])
    J = np.diag([2.0, 2.0 * og])
    C = J @ R @ np.diag([0.5 / lam, 0.5 / mu]) @ R.T @ J
    return C, e_par, e_perp, og


def _eig2(C):
    """(σ²_min, σ²_max, unit eigenvector of σ²_max) of a symmetric 2×2 matrix."""
    a, b, d = C[0, 0], C[0, 1], C[1, 1]
    m, r = 0.5 * (a + d), np.hypot(0.5 * (a - d), b)
    lo, hi = max(m - r, 1e-30), m + r
    v = np.array([b, hi - a]) if abs(b) > 1e-30 * (abs(a) + abs(d)) else (
        np.array([1.0, 0.0]) if a >= d else np.array([0.0, 1.0]))
    return lo, hi, v / np.linalg.norm(v)


@dataclass
class SubLobes:
    """Isotropic SG lobes G(i; axis, sharpness, amplitude) in light (i) space."""

    axis: np.ndarray        # (K, 3)
    sharpness: np.ndarray   # (K,)
    amplitude: np.ndarray   # (K,)

    def eval(self, i):
        i = np.asarray(i, float)
        return np.exp(self.sharpness * (i @ self.axis.T - 1.0)) @ self.amplitude

    def integral(self) -> float:
        k = self.sharpness
        return float(np.sum(self.amplitude * 2 * np.pi * -np.expm1(-2 * k) / k))


def asg_sublobes(o, z, x, lam, mu, c=1.0, max_half: int = MAX_HALF,
                 spacing: float = SPACING_SIGMAS, range_sigmas: float = RANGE_SIGMAS,
                 merge_from: float | None = None) -> SubLobes:
    """An h-space ASG seen from view o as isotropic SGs in i-space approximating G(h(i)),
    h = (o + i)/‖o + i‖ (kernels/include/asg.h, asg_plan / asg_sublobe, mirror this).

    At the lobe axis the half-vector Jacobian (×2 in the plane of incidence, ×2(o·z) across it;
    Xu13 §5's warp) turns the ASG's covariance into an i-space one with eigenvalues σ²_min ≤
    σ²_max along r. That Gaussian is exactly an isotropic Gaussian of σ_min convolved with a
    line density of variance σ²_max − σ²_min along r, so the sub-lobes are isotropic SGs of
    σ_min at nodes spaced ≤ 1.75 σ_min along r's preimage in h (a great circle through z), each
    node warped exactly (i_k = 2(o·h_k)h_k − o: the chain bends as the true highlight does), its
    h-space mass share times the Jacobian 4(o·h_k) as its i-space integral and its σ from the
    local warp. Beyond `max_half` nodes per side the nodes spread and their σ grows with them.
    `spacing` (in σ_min) and `range_sigmas` default to the dense set; the kernel uses
    KERNEL_SPACING_SIGMAS, KERNEL_RANGE_SIGMAS and merges the nodes beyond KERNEL_MERGE_FROM σ
    of the line in neighbouring pairs (`merge_from`; None: no merging)."""
    o, z, x = (np.asarray(a, float) for a in (o, z, x))
    og0 = float(o @ z)
    empty = SubLobes(np.zeros((0, 3)), np.zeros(0), np.zeros(0))
    if og0 <= 1e-4:
        return empty
    mass = float(asg_mass(lam, mu, c))
    C, e_par, e_perp, _ = _warped_cov(o, z, x, lam, mu)
    s_min, s_max, r = _eig2(C)
    v = s_max - s_min
    if v <= 0.09 * s_min:
        # one lobe: the geometric-mean σ (Wang09's isotropic warp), integral kept
        kap = 1.0 / np.sqrt(s_min * s_max)
        i0 = 2 * og0 * z - o
        return SubLobes(i0[None], np.array([kap]),
                        np.array([4 * og0 * mass / _sg_unit(kap)]))
    uh = r[0] / 2.0 * e_par + r[1] / (2.0 * og0) * e_perp      # J⁻¹ r (h-space, ⊥ z)
    ell = float(np.linalg.norm(uh))
    uh /= ell
    sd = np.sqrt(v)
    n = max(int(min(np.ceil(range_sigmas * sd / (spacing * np.sqrt(s_min))), max_half)), 1)
    dt = range_sigmas * sd / n
    dt = min(dt, 1.5 / (ell * n))                               # nodes stay in the hemisphere
    sig_floor = dt / FLOOR_SIGMAS
    v_line = max(s_max - max(s_min, sig_floor ** 2), 0.0) * ell * ell   # h-space, deconvolved
    ks = np.arange(-n, n + 1)
    s = ks * dt * ell
    w = np.cos(s) * np.exp(-np.sin(s) ** 2 / (2 * max(v_line, 1e-30)))
    w /= w.sum()
    s, w, vh = _merge_pairs(s, w, n, merge_from, range_sigmas)
    axes, kaps, amps = [], [], []
    for sk, wk, vk in zip(s, w, vh):
        h = np.cos(sk) * z + np.sin(sk) * uh
        og = float(o @ h)
        if og <= 1e-4:
            continue
        Ck, ep_k, pp_k, _ = _warped_cov(o, h, x, lam, mu)
        smin_k = _eig2(Ck)[0]
        t = -np.sin(sk) * z + np.cos(sk) * uh
        jt = 2.0 * np.sqrt((t @ ep_k) ** 2 + og * og * (t @ pp_k) ** 2)
        # a merged pair: the geometric-mean variance of (σ²_min, σ²_min + pair variance)
        sig2 = np.sqrt(smin_k * (smin_k + vk * jt * jt)) if vk > 0 else smin_k
        kap = 1.0 / max(sig2, (dt * ell * jt / FLOOR_SIGMAS) ** 2)
        axes.append(2 * og * h - o)
        kaps.append(kap)
        amps.append(4 * og * mass * wk / _sg_unit(kap))
    if not axes:
        return empty
    return SubLobes(np.array(axes), np.array(kaps), np.array(amps))


def _merge_pairs(s, w, n, merge_from, range_sigmas):
    """Nodes (s over k = −n … n, weights w) with those beyond merge_from σ of the line merged in
    neighbouring pairs by exact moments: (positions, weights, pair variances along the line)."""
    if merge_from is None:
        return s, w, np.zeros_like(s)
    m = min(n, int(np.ceil(merge_from / range_sigmas * n)))
    out = []
    for sign in (1, -1):
        a = m + 1
        while a <= n:
            b = min(a + 1, n)
            ia, ib = n + sign * a, n + sign * b
            wa, wb = w[ia], (w[ib] if b > a else 0.0)
            sa, sb = s[ia], s[ib]
            out.append(((wa * sa + wb * sb) / (wa + wb), wa + wb,
                        wa * wb * (sb - sa) ** 2 / (wa + wb) ** 2))
            a += 2
    inner = [(s[n + k], w[n + k], 0.0) for k in range(-m, m + 1)]
    arr = np.array(inner + out)
    return arr[:, 0], arr[:, 1], arr[:, 2]


def _sg_unit(k):
    """∫ e^{κ(v·p − 1)} dω = 2π(1 − e^{−2κ})/κ."""
    return 2 * np.pi * -np.expm1(-2 * k) / k


def basis_around(a):
    """Orthonormal (u, v) around unit a (Duff et al. 2017), as kernels/include/sg.h."""
    a = np.asarray(a, float)
    s = 1.0 if a[2] >= 0 else -1.0
    p = -1.0 / (s + a[2])
    q = a[0] * a[1] * p
    return (np.array([1 + s * a[0] * a[0] * p, s * q, -s * a[0]]),
            np.array([q, s + a[1] * a[1] * p, -a[1]]))


def x_angle(z, x) -> float:
    """Angle φ of the sharp axis x about z from basis_around(z)'s u (the lobe record's φ)."""
    u, v = basis_around(z)
    return float(np.arctan2(np.dot(x, v), np.dot(x, u)))
