"""Real spherical harmonics (orthonormal, graphics convention without the Condon–Shortley phase).

Convention: polar axis +Z of the vectors passed in (use local z-up frames, or pass world
vectors knowing that +Z is the pole), index k = l(l + 1) + m, and
  Y_lm = √2 K_lm P_l^m(cos θ) cos(mφ)   (m > 0),
  Y_l0 = K_l0 P_l(cos θ),
  Y_lm = √2 K_l|m| P_l^|m|(cos θ) sin(|m|φ)   (m < 0),
with K_lm = sqrt((2l+1)/(4π) (l−m)!/(l+m)!) and P_l^m WITHOUT the (−1)^m factor, so that
Y_1,−1 = c·y, Y_10 = c·z, Y_11 = c·x with c = sqrt(3/(4π)) (Ramamoorthi–Hanrahan 2001; Sloan).
Evaluation uses sin^m θ (cos mφ, sin mφ) = (Re, Im)(x + iy)^m, so it is exact at the poles.
"""
from __future__ import annotations

import math
from math import factorial

import numpy as np
from scipy.special import eval_legendre


def sh_index(l, m):
    """Flat coefficient index of (l, m)."""
    return l * (l + 1) + m


def sh_eval(dirs, lmax):
    """Real SH basis at unit directions (..., 3) → (..., (lmax+1)²)."""
    d = np.asarray(dirs, float)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    out = np.empty(d.shape[:-1] + ((lmax + 1) ** 2,))
    # (x + iy)^m by recurrence
    cm, sm = np.ones_like(x), np.zeros_like(x)
    pmm = np.ones_like(z)  # reduced P_m^m / sin^m θ = (2m−1)!!
    for m in range(lmax + 1):
        if m > 0:
            cm, sm = cm * x - sm * y, cm * y + sm * x
            pmm = pmm * (2 * m - 1)
        p_prev2 = None
        p_prev = pmm
        for l in range(m, lmax + 1):
            if l == m:
                p = pmm
            elif l == m + 1:
                p = z * (2 * m + 1) * pmm
            else:
                p = ((2 * l - 1) * z * p_prev - (l + m - 1) * p_prev2) / (l - m)
            if l > m:
                p_prev2, p_prev = p_prev, p
            k = np.sqrt((2 * l + 1) / (4 * np.pi) * factorial(l - m) / factorial(l + m))
            if m == 0:
                out[..., sh_index(l, 0)] = k * p
            else:
                out[..., sh_index(l, m)] = np.sqrt(2.0) * k * p * cm
                out[..., sh_index(l, -m)] = np.sqrt(2.0) * k * p * sm
            if l == m:
                p_prev2, p_prev = None, pmm
    return out


def sh_project(values, dirs, weights, lmax):
    """Coefficients c_k = Σ_n w_n f_n Y_k(d_n); values (N,) → (K,), (N, C) → (K, C)."""
    Y = sh_eval(dirs, lmax) * np.asarray(weights, float)[:, None]
    return np.tensordot(Y, np.asarray(values, float), axes=(0, 0))


def sh_reconstruct(coeffs, dirs):
    """f(d) = Σ_k c_k Y_k(d); coeffs (K,) or (K, C)."""
    coeffs = np.asarray(coeffs, float)
    lmax = int(round(np.sqrt(coeffs.shape[0]))) - 1
    return np.tensordot(sh_eval(dirs, lmax), coeffs, axes=(-1, 0))


def sh_irradiance_coeffs(lmax):
    """Ramamoorthi–Hanrahan 2001: Â_l with E_lm = Â_l L_lm for the kernel max(0, cos θ).

    Â_0 = π, Â_1 = 2π/3, Â_l = 0 for odd l > 1,
    Â_l = 2π (−1)^{l/2−1} / ((l+2)(l−1)) · l! / (2^l ((l/2)!)²) for even l >= 2.
    Returns shape (lmax+1,); use ``sh_expand_bands`` for a per-coefficient vector.
    """
    a = np.zeros(lmax + 1)
    for l in range(lmax + 1):
        if l == 0:
            a[l] = np.pi
        elif l == 1:
            a[l] = 2.0 * np.pi / 3.0
        elif l % 2 == 0:
            h = l // 2
            a[l] = (2.0 * np.pi * (-1) ** (h - 1) / ((l + 2) * (l - 1))
                    * factorial(l) / (2**l * factorial(h) ** 2))
    return a


def sh_expand_bands(per_band):
    """Repeat a per-band array (lmax+1,) to per-coefficient ((lmax+1)²,)."""
    per_band = np.asarray(per_band)
    return np.repeat(per_band, 2 * np.arange(per_band.shape[0]) + 1, axis=0)


# θ subintervals for ρ̂_l quadrature: geometric near the pole, where sharp lobes live.
_THETA_EDGES = np.array([0.0, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 0.7, 1.2, math.pi / 2,
                         2.2, math.pi])
_NODES = 48


def zonal_theta_rule() -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes θ and weights for ∫₀^π g(θ) sin θ dθ (composite, exact for the
    polynomial pieces; the kink of max(u, 0) sits on the edge π/2)."""
    x, w = np.polynomial.legendre.leggauss(_NODES)
    th, wt = [], []
    for a, b in zip(_THETA_EDGES[:-1], _THETA_EDGES[1:]):
        th.append(0.5 * (b - a) * x + 0.5 * (b + a))
        wt.append(0.5 * (b - a) * w)
    th = np.concatenate(th)
    return th, np.concatenate(wt) * np.sin(th)


def zonal_coeffs(f, lmax: int) -> np.ndarray:
    """ρ̂_l = 2π ∫_{−1}^{1} f(u) P_l(u) du for l = 0..lmax of a radially symmetric f(u), u the
    cosine to its axis (eq 11: ρ̂_l = √(4π/(2l+1)) f_l)."""
    th, w = zonal_theta_rule()
    u = np.cos(th)
    fu = np.asarray(f(u), float)
    return np.array([2.0 * math.pi * float(np.sum(w * fu * eval_legendre(l, u)))
                     for l in range(lmax + 1)])
