"""Spherical Gaussians G(v; p, λ, μ) = μ e^{λ(v·p − 1)} (Wang09 §3, eq 2–7, 17–21, 40).

Broadcasting rules used by every function here:
  * directions have shape (..., 3); sharpness λ and amplitude μ broadcast against the
    lobe shape (...), i.e. the direction shape without its last axis;
  * an amplitude may carry ONE extra trailing axis (e.g. RGB, shape (..., 3)) when its
    ndim exceeds the lobe factor's ndim; the lobe factor is then broadcast over that axis
    (see ``_scale_amp``). For one RGB lobe evaluated at N directions pass μ of shape (1, 3)
    (a bare (3,) μ against (N,) values is ordinary numpy broadcasting, NOT a colour axis).
All closed forms are written in overflow-free form: only e^{x} with x <= 0 is evaluated.
"""
from __future__ import annotations

import numpy as np

#: Wang09 eq 40 single-lobe fit of max(0, cos θ) (published values, used by the renderer).
CLAMPED_COSINE_LAMBDA = 2.133
CLAMPED_COSINE_MU = 1.170

_TWO_PI = 2.0 * np.pi


def _scale_amp(scale, mu):
    """Multiply a per-lobe scalar factor by an amplitude that may have a trailing colour axis."""
    scale = np.asarray(scale, dtype=float)
    mu = np.asarray(mu, dtype=float)
    if mu.ndim > scale.ndim and scale.ndim > 0:
        return scale[..., None] * mu
    return scale * mu


def _amp_mul(a, b):
    """μ1·μ2 where one factor may carry an extra trailing colour axis."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim == b.ndim + 1 and b.ndim > 0:
        return a * b[..., None]
    if b.ndim == a.ndim + 1 and a.ndim > 0:
        return a[..., None] * b
    return a * b


def _dot(a, b):
    return np.sum(np.asarray(a, float) * np.asarray(b, float), axis=-1)


def _sinhc_ratio(d):
    """(1 − e^{−2d}) / d, stable for d → 0 (limit 2); d >= 0."""
    d = np.asarray(d, dtype=float)
    small = d < 1e-12
    ds = np.where(small, 1.0, d)
    return np.where(small, 2.0 - 2.0 * d, -np.expm1(-2.0 * ds) / ds)


def sg_eval(v, p, lam, mu):
    """Wang09 eq 2: G(v; p, λ, μ) = μ e^{λ(v·p − 1)}."""
    return _scale_amp(np.exp(np.asarray(lam, float) * (_dot(v, p) - 1.0)), mu)


def sg_product(p1, lam1, mu1, p2, lam2, mu2):
    """Wang09 eq 5 / appendix eq 45: G1·G2 = G(v; p_m/‖p_m‖, λ_m‖p_m‖, μ1μ2 e^{λ_m(‖p_m‖−1)})."""
    lam1 = np.asarray(lam1, float)
    lam2 = np.asarray(lam2, float)
    pv = lam1[..., None] * np.asarray(p1, float) + lam2[..., None] * np.asarray(p2, float)
    d = np.linalg.norm(pv, axis=-1)                     # = λ_m ‖p_m‖
    lam_m = lam1 + lam2
    # Antipodal equal lobes give a constant (d = 0): any axis, sharpness 0.
    safe = d > 0
    p1b = np.broadcast_to(np.asarray(p1, float), pv.shape)
    axis = np.where(safe[..., None], pv / np.where(safe, d, 1.0)[..., None], p1b)
    mu = _scale_amp(np.exp(d - lam_m), _amp_mul(mu1, mu2))
    return axis, d, mu


def sg_inner(p1, lam1, mu1, p2, lam2, mu2):
    """Wang09 eq 4: ∫ G1 G2 = 4π μ1μ2 e^{−λm} sinh(d)/d = 2π μ1μ2 e^{d−λm}(1−e^{−2d})/d, d=‖λ1p1+λ2p2‖."""
    lam1 = np.asarray(lam1, float)
    lam2 = np.asarray(lam2, float)
    pv = lam1[..., None] * np.asarray(p1, float) + lam2[..., None] * np.asarray(p2, float)
    d = np.linalg.norm(pv, axis=-1)
    val = _TWO_PI * np.exp(d - (lam1 + lam2)) * _sinhc_ratio(d)
    return _scale_amp(val, _amp_mul(mu1, mu2))


def sg_integral(lam, mu):
    """∫_{S²} G = 2πμ/λ (1 − e^{−2λ}) (limit 4πμ as λ → 0)."""
    return _scale_amp(_TWO_PI * _sinhc_ratio(np.asarray(lam, float)), mu)


def dln_sg_norm(lam):
    """Wang09 eq 35's S(λ) = ∫G(·; p, λ, 1): its log-slope ∂ln S/∂ln λ = 2λ/(e^{2λ} − 1) − 1."""
    lam = np.asarray(lam, float)
    x = np.clip(2.0 * lam, 1e-300, 700.0)     # 700: e^{2λ} stays finite; the slope is −1 there
    return np.where(lam < 1e-8, -lam, x / np.expm1(x) - 1.0)


def sg_rotate(R, p):
    """Wang09 eq 7: a rotated lobe keeps λ, μ and has axis R p (R: (..., 3, 3))."""
    return np.einsum("...ij,...j->...i", np.asarray(R, float), np.asarray(p, float))


def sg_support_area(lam, eps=0.1):
    """Wang09 eq 3: f_a(λ) = −2π ln ε / λ, area where G(v; z, λ, 1) >= ε (exact for λ > −ln ε)."""
    return -_TWO_PI * np.log(eps) / np.asarray(lam, float)


def sg_sharpness_from_area(area, eps=0.1):
    """Inverse of Wang09 eq 3: f_a^{-1}(A) = −2π ln ε / A."""
    return -_TWO_PI * np.log(eps) / np.asarray(area, float)


def sg_warp(p, lam, mu, o):
    """Wang09 eq 17–21: NDF lobe in h-space → slice lobe in i-space (ψ(h) = 2(o·h)h − o).

    Axis ψ(p); area scales by τ = di/dh = 4|o·p| so λ_W = λ/(4|o·p|) (eq 19); μ kept (eq 20).
    |o·p| is floored at 1e-6 to keep λ_W finite at exactly grazing configurations.
    """
    p = np.asarray(p, float)
    o = np.asarray(o, float)
    op = _dot(o, p)
    p_s = 2.0 * op[..., None] * p - o
    p_s = p_s / np.linalg.norm(p_s, axis=-1, keepdims=True)
    lam_s = np.asarray(lam, float) / (4.0 * np.maximum(np.abs(op), 1e-6))
    lam_s = np.broadcast_to(lam_s, np.broadcast_shapes(lam_s.shape, op.shape)).copy()
    mu_s = _scale_amp(np.ones(lam_s.shape), mu)
    return p_s, lam_s, mu_s


def clamped_cosine_l2_error(lam, mu):
    """‖μ e^{λ(cosθ−1)} − max(0, cosθ)‖_{L2(S²)}, closed form (no quadrature)."""
    lam = np.asarray(lam, float)
    mu = np.asarray(mu, float)
    # ∫ G² = 2π μ² (1−e^{−4λ})/(2λ);  ∫_{t>0} t G = 2π μ ∫_0^1 t e^{λ(t−1)} dt;  ∫ max(0,t)² = 2π/3
    g2 = _TWO_PI * mu**2 * _sinhc_ratio(2.0 * lam)
    cross = _TWO_PI * mu * _int_t_exp(lam)
    ise = g2 - 2.0 * cross + _TWO_PI / 3.0
    return np.sqrt(np.maximum(ise, 0.0))


def _int_t_exp(lam):
    """∫_0^1 t e^{λ(t−1)} dt = 1/λ − (1 − e^{−λ})/λ² (series for small λ)."""
    lam = np.asarray(lam, float)
    small = lam < 1e-4
    ls = np.where(small, 1.0, lam)
    big = 1.0 / ls + np.expm1(-ls) / ls**2
    return np.where(small, 0.5 - lam / 6.0, big)


def fit_clamped_cosine_sg():
    """Own least-squares single-SG fit of max(0, cos θ) over S² (compare Wang09 eq 40).

    Returns (λ, μ, l2_error) minimising ∫_{S²} (μ e^{λ(cosθ−1)} − max(0, cosθ))² dω; for fixed λ
    the optimal μ is linear (μ* = ∫tG₁ / ∫G₁²), leaving a 1-D minimisation in λ.
    """
    from scipy.optimize import minimize_scalar

    def mu_opt(lam):
        return _int_t_exp(lam) / _sinhc_ratio(2.0 * lam)

    res = minimize_scalar(lambda lam: float(clamped_cosine_l2_error(lam, mu_opt(lam))),
                          bounds=(0.1, 20.0), method="bounded",
                          options={"xatol": 1e-10})
    lam = float(res.x)
    mu = float(mu_opt(lam))
    return lam, mu, float(clamped_cosine_l2_error(lam, mu))


def clamped_cosine_sg(n, lam=CLAMPED_COSINE_LAMBDA, mu=CLAMPED_COSINE_MU):
    """Wang09 eq 40: C*(i; n) = G(i; n, 2.133, 1.170) ≈ max(0, i·n). Returns (p, λ, μ)."""
    n = np.asarray(n, float)
    shape = n.shape[:-1]
    return n.copy(), np.full(shape, float(lam)), np.full(shape, float(mu))
