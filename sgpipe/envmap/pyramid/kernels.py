"""Zonal kernels of the Γ_L pyramid's chained levels (Wang09 eq 34–35).

Level b is computed from level a (λ_a > λ_b) instead of from the map: on S² two zonal kernels
compose by multiplying their Legendre coefficients (Funk–Hecke), and the normalized SG
K_λ(x) = e^{λ(x−1)}/S(λ) has k_l(λ) = I_{l+½}(λ)/I_{½}(λ). So V_b = V_a ⊗ Δ exactly for the
zonal "difference kernel" with Δ_l = k_l(λ_b)/k_l(λ_a). Δ is not an SG (SG ⊗ SG is not an SG:
2.6e-3 … 0.5 off for λ 16384 … 64), but it is exp of a quartic in u = 1 − x to ≤ 1e-5 for
λ_a ≥ 128 (4e-4 at 32 → 22.6, 1e-3 at 22.6 → 16: the pyramid chains down to λ 20);
`difference_kernel` returns that fit in the gather's `kern` layout.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.special import ive

from sgpipe.core.sg import sg_integral
from sgpipe.envmap.pyramid._kernels_jit import legendre_series

_NU = 48                                # fit nodes on [0, u_cut]


def sg_legendre(lam: float, lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """(k_l, dk_l/dλ), l = 0..lmax, of the normalized SG K_λ (k_0 = 1)."""
    l = np.arange(lmax + 2) + 0.5
    i = ive(l, lam)                     # e^{−λ} I_ν(λ): the scale cancels in the ratios
    k = i[:-1] / i[0]
    di = i[1:] + l[:-1] / lam * i[:-1]  # I'_ν = I_{ν+1} + (ν/λ) I_ν
    dk = (di * i[0] - i[:-1] * (i[1] + 0.5 / lam * i[0])) / i[0] ** 2
    return k, dk


def _dsg_norm(lam):
    """dS/dλ of S(λ) = 2π(1 − e^{−2λ})/λ."""
    e = math.exp(-2.0 * lam)
    return 2.0 * math.pi * (2.0 * lam * e - (1.0 - e)) / (lam * lam)


def sg_kernel(lam: float, tail: float) -> np.ndarray:
    """`kern` of the plain SG e^{λ(x−1)} (Γ and ∂Γ/∂λ over point masses; no amplitude)."""
    return np.array([lam, 0.5 * tail * tail, -1.0, 0.0, 0.0, 0.0,
                     0.0, -1.0 / lam, 0.0, 0.0])


def difference_kernel(lam_a: float, lam_b: float, tail: float = 4.5):
    """Chain step a → b: (kern, amplitude, fit error) such that, over the level-a samples as
    quadrature masses E = V_a·w (`chain.chain_source`), Γ_b = amplitude · Σ E k and
    ∂Γ_b/∂λ_b = amplitude · Σ E k r with k, r the kernel and ratio of `_gather_jit._poly_tap`.

    The kernels are S_b·Δ and S_b'·Δ + S_b·∂Δ/∂λ_b, cut at `tail` standard deviations of Δ
    (σ² = 1/λ_d, 1/λ_d = 1/λ_b − 1/λ_a) with the amplitude renormalised so the cut kernel still
    integrates to S_b. The fit error is the largest relative error of the fitted S_b·Δ weighted
    by Δ/Δ(0) (what a map sees)."""
    lam_d = 1.0 / (1.0 / lam_b - 1.0 / lam_a)
    lmax = int(math.sqrt(80.0 * lam_d) + 40)
    ka, _ = sg_legendre(lam_a, lmax)
    kb, dkb = sg_legendre(lam_b, lmax)
    keep = ka > 1e-300
    s_b, ds_b = float(sg_integral(lam_b, 1.0)), _dsg_norm(lam_b)
    coef = np.zeros((2, lmax + 1))
    coef[0, keep] = kb[keep] / ka[keep]
    coef[1, keep] = (ds_b * kb[keep] + s_b * dkb[keep]) / ka[keep]
    zcut = 0.5 * tail * tail
    ucut = min(2.0, zcut / lam_d)
    # Chebyshev-spaced nodes on [0, u_cut] (dense at both ends)
    u = 0.5 * ucut * (1.0 - np.cos(np.linspace(0.0, math.pi, _NU)))
    dk, dd = legendre_series(coef, 1.0 - u)
    if dk.min() <= 0.0:
        raise ValueError(f"difference kernel λ {lam_a:g} → {lam_b:g} is not positive")
    z = u * lam_d
    d0 = float(dk[0])
    w = np.sqrt(dk / d0)
    # ln(Δ/Δ(0)) = z(k1 + z(k2 + z(k3 + z k4)))
    A = np.stack([z, z ** 2, z ** 3, z ** 4], axis=1)
    k = np.linalg.lstsq(A * w[:, None], np.log(dk / d0) * w, rcond=None)[0]
    # derivative kernel over S_b·Δ: g0 + z(g1 + z(g2 + z g3)), weighted the same
    B = np.stack([np.ones_like(z), z, z ** 2, z ** 3], axis=1)
    g = np.linalg.lstsq(B * w[:, None], dd / (s_b * dk) * w, rcond=None)[0]
    fit = d0 * np.exp(A @ k)
    err = float(np.max(np.abs(fit / dk - 1.0) * dk / d0))
    # amplitude: the cut kernel integrates to S_b (dΩ = 2π du; trapezoid on a fine grid)
    uf = np.linspace(0.0, ucut, 4001)
    zf = uf * lam_d
    wf = np.exp(zf * (k[0] + zf * (k[1] + zf * (k[2] + zf * k[3]))))
    amp = s_b / (2.0 * math.pi * float(np.sum((wf[1:] + wf[:-1]) * 0.5 * np.diff(uf))))
    kern = np.array([lam_d, zcut, k[0], k[1], k[2], k[3], g[0], g[1], g[2], g[3]])
    return kern, amp, err
