"""SG × SSDF visibility integral f_h (Wang09 eq 25–31) and its sigmoid fit (appendix eq 46–49).

Re-derived meaning of eq 25–30 (the extraction is garbled): the SSDF value θ_d at the lobe
axis p is the signed angular distance from p to the nearest visibility boundary (> 0 when p
is visible). The reconstructed visibility V′ is the HEMISPHERE {i : i·q >= 0} whose boundary
great circle passes at angular distance |θ_d| from p, with p inside iff θ_d > 0, i.e.
p·q = sin θ_d. Then

    f_h(θ_d, λ) = ∫_{i·q >= 0} G(i; p, λ, 1) dω          (unit-amplitude SG, not unit-integral)

so f_h(π/2, λ) = 2π(1 − e^{−λ})/λ (hemisphere about p, as eq 31 states),
f_h(0, λ) = π(1 − e^{−2λ})/λ, f_h(−π/2, λ) = 2π(e^{−λ} − e^{−2λ})/λ and
f_h(θ) + f_h(−θ) = ∫_{S²} G. Slicing the visible hemisphere by circles i·q = sin α
(α ∈ [0, π/2] = elevation above the horizon) and integrating e^{λ i·p} around each circle
(a Bessel I₀) gives the smooth 1-D integral used by ``fh_exact``:

    f_h = 2π ∫_0^{π/2} e^{λ(cos(α − θ_d) − 1)} · i0e(λ cos θ_d cos α) · cos α dα,

with i0e(z) = e^{−z} I₀(z). It is integrated by Gauss–Legendre after the substitution
α = α* + σ sinh u (α* = clip(θ_d, 0, π/2), σ = min(1/√λ, 1)), which resolves lobes of any
sharpness.

The appendix sigmoid (eq 47) is garbled as “a/(1 + k e^{θ_d}) + (1−a)/2”; that form is
DECREASING in θ_d and is not 1/2 at θ_d = 0. The consistent reading, used here, is
    σ(θ_d; k) = a / (1 + e^{−k θ_d}) + (1 − a)/2,   a = 1.05,
    k = f_k(λ) = c₃λ³ + c₂λ² + c₁λ + c₀   (eq 48: 0.204, −0.892, 2.995, 0.067),
    f_h ≈ σ(θ_d; f_k(λ)) · f_h(π/2, λ)   (eq 49).
See docs/MATH.md for the integrated-error comparison with the published 5.5e-4.
"""
from __future__ import annotations

import numpy as np
from scipy.special import i0e

from .quadrature import gauss_legendre

_TWO_PI = 2.0 * np.pi

#: Wang09 eq 47–48 as published: (a, c3, c2, c1, c0), k = c3 λ³ + c2 λ² + c1 λ + c0.
PUBLISHED_FH_COEFFS = (1.05, 0.204, -0.892, 2.995, 0.067)

#: Own least-squares refit of the same form on θ_d ∈ [−π/2, π/2], λ ∈ [1, 105]
#: with a free (MSE 1.99e-4 vs 1.48e-2 published); regenerate with `python -m sgpipe.core.fh`.
#: Only fitted for λ in FH_LAMBDA_RANGE; outside it the cubic grows like λ³ (near-step sigmoid).
REFIT_FH_COEFFS = (1.0030395053370436, 3.272151429400235e-05, -0.005917952727578048,
                   0.43016130100686034, 1.1536279051439047)

#: Integration domain of the published error (appendix, last equation).
FH_THETA_RANGE = (-np.pi / 2, np.pi / 2)
FH_LAMBDA_RANGE = (1.0, 105.0)


def fh_hemisphere(lam):
    """Wang09 eq 31: f_h(π/2, λ) = ∫_{hemisphere about p} G(i; p, λ, 1) = 2π(1 − e^{−λ})/λ."""
    lam = np.asarray(lam, float)
    small = lam < 1e-12
    ls = np.where(small, 1.0, lam)
    return np.where(small, _TWO_PI * (1.0 - 0.5 * lam), -_TWO_PI * np.expm1(-ls) / ls)


def fh_exact(theta_d, lam, n=96):
    """Wang09 eq 30 by quadrature (see module docstring); broadcasts θ_d and λ."""
    th, lam = np.broadcast_arrays(np.asarray(theta_d, float), np.asarray(lam, float))
    th = np.clip(th, -np.pi / 2, np.pi / 2)
    astar = np.clip(th, 0.0, np.pi / 2)
    sig = np.minimum(1.0 / np.sqrt(np.maximum(lam, 1e-300)), 1.0)
    ua = np.arcsinh((0.0 - astar) / sig)
    ub = np.arcsinh((np.pi / 2 - astar) / sig)
    x, w = gauss_legendre(n, 0.0, 1.0)
    u = ua[..., None] + (ub - ua)[..., None] * x
    alpha = astar[..., None] + sig[..., None] * np.sinh(u)
    jac = (ub - ua)[..., None] * sig[..., None] * np.cosh(u) * w
    L = lam[..., None]
    ca = np.cos(alpha)
    f = np.exp(L * (np.cos(alpha - th[..., None]) - 1.0)) * i0e(L * np.cos(th)[..., None] * ca) * ca
    return _TWO_PI * np.sum(f * jac, axis=-1)


def fh_hat_exact(theta_d, lam, n=96):
    """Wang09 eq 46: normalised f̂_h = f_h / f_h(π/2, λ) ∈ (0, 1]."""
    return fh_exact(theta_d, lam, n) / fh_hemisphere(lam)


def fh_k(lam, coeffs=PUBLISHED_FH_COEFFS):
    """Wang09 eq 48: sigmoid steepness k = f_k(λ) (cubic polynomial)."""
    _, c3, c2, c1, c0 = coeffs
    lam = np.asarray(lam, float)
    return ((c3 * lam + c2) * lam + c1) * lam + c0


def fh_hat_sigmoid(theta_d, lam, coeffs=PUBLISHED_FH_COEFFS):
    """Wang09 eq 47 (re-derived sign): σ = a/(1 + e^{−f_k(λ) θ_d}) + (1 − a)/2."""
    a = coeffs[0]
    k = fh_k(lam, coeffs)
    z = -k * np.asarray(theta_d, float)
    # 1/(1+e^z) written without overflow
    s = np.where(z > 0, np.exp(-np.abs(z)) / (1.0 + np.exp(-np.abs(z))), 1.0 / (1.0 + np.exp(-np.abs(z))))
    return a * s + 0.5 * (1.0 - a)


def fh_sigmoid(theta_d, lam, coeffs=PUBLISHED_FH_COEFFS):
    """Wang09 eq 49: f_h(θ_d, λ) ≈ σ(θ_d; f_k(λ)) · f_h(π/2, λ) (un-normalised, like fh_exact)."""
    return fh_hat_sigmoid(theta_d, lam, coeffs) * fh_hemisphere(lam)


def _composite_gl(a, b, panels, order):
    e = np.linspace(a, b, panels + 1)
    x, w = gauss_legendre(order, 0.0, 1.0)
    h = np.diff(e)
    return (e[:-1, None] + h[:, None] * x).ravel(), (h[:, None] * w).ravel()


def fh_sigmoid_ise(coeffs=PUBLISHED_FH_COEFFS, theta_range=FH_THETA_RANGE,
                   lam_range=FH_LAMBDA_RANGE, panels=(64, 104), order=8):
    """Appendix error: ∫∫ (f̂_h − σ)² dλ dθ_d by composite Gauss–Legendre (dλ uniform).

    Returns (ise, mse) with mse = ise / domain area.
    """
    th, wt = _composite_gl(*theta_range, panels[0], order)
    lam, wl = _composite_gl(*lam_range, panels[1], order)
    T, L = np.meshgrid(th, lam, indexing="ij")
    r = fh_hat_exact(T, L) - fh_hat_sigmoid(T, L, coeffs)
    ise = float(np.einsum("ij,i,j->", r * r, wt, wl))
    area = (theta_range[1] - theta_range[0]) * (lam_range[1] - lam_range[0])
    return ise, ise / area


def refit_fh_sigmoid(theta_range=FH_THETA_RANGE, lam_range=FH_LAMBDA_RANGE,
                     panels=(32, 52), order=8, fix_a=None):
    """Own least-squares fit of (a, c3, c2, c1, c0) minimising the appendix ISE (same weights).

    fix_a: keep a fixed (the paper uses 1.05) and fit only the cubic.
    """
    from scipy.optimize import least_squares

    th, wt = _composite_gl(*theta_range, panels[0], order)
    lam, wl = _composite_gl(*lam_range, panels[1], order)
    T, L = np.meshgrid(th, lam, indexing="ij")
    target = fh_hat_exact(T, L)
    sw = np.sqrt(np.outer(wt, wl))

    def unpack(x):
        return tuple(float(v) for v in ((fix_a,) + tuple(x) if fix_a is not None else tuple(x)))

    def resid(x):
        return ((fh_hat_sigmoid(T, L, unpack(x)) - target) * sw).ravel()

    # Start from a moderate steepness: the published cubic saturates the sigmoid at once.
    start = np.array([0.0, 0.0, 0.15, 1.5]) if fix_a is not None else np.array([1.0, 0.0, 0.0, 0.15, 1.5])
    sol = least_squares(resid, start, x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                        max_nfev=2000)
    return unpack(sol.x)


if __name__ == "__main__":  # pragma: no cover - regenerates REFIT_FH_COEFFS and the MATH.md numbers
    for name, c in (("published", PUBLISHED_FH_COEFFS), ("refit", REFIT_FH_COEFFS)):
        print(name, c, "ISE, MSE =", fh_sigmoid_ise(c, panels=(128, 208)))
    print("refit (free a):", refit_fh_sigmoid())
    print("refit (a = 1.05):", refit_fh_sigmoid(fix_a=1.05))
