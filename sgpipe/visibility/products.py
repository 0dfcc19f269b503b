"""Products of SG lobes with SSDF visibility (Wang09 eq 28–31) and their ray-traced reference.

θ_d = S(p) is the SSDF at the lobe axis; the visible region is modelled as the hemisphere
whose boundary passes at angle θ_d from p (see sgpipe.core.fh for the derivation of f_h).
"""

from __future__ import annotations

import numpy as np

from sgpipe.core.fh import (PUBLISHED_FH_COEFFS, REFIT_FH_COEFFS, fh_exact, fh_hemisphere,
                            fh_sigmoid)
from sgpipe.core.quadrature import polar_frame

#: f_h variants: the exact integral (quadrature), the appendix sigmoid with the foundation's
#: refit coefficients (fit on λ ∈ [1, 105]) and with the published ones (Wang09 eq 47–49).
FH_METHODS = ("exact", "sigmoid", "sigmoid_published")


def _fh(theta_d, lam, method: str):
    th = np.clip(np.asarray(theta_d, float), -np.pi / 2, np.pi / 2)
    if method == "exact":
        return fh_exact(th, lam)
    if method == "sigmoid":
        return fh_sigmoid(th, lam, REFIT_FH_COEFFS)
    if method == "sigmoid_published":
        return fh_sigmoid(th, lam, PUBLISHED_FH_COEFFS)
    raise ValueError(f"unknown f_h method {method!r} ({', '.join(FH_METHODS)})")


def sg_visibility_integral(theta_d, lam, mu=1.0, *, fh: str = "exact"):
    """Wang09 eq 28–30: ∫ G(i; p, λ, μ) V(i) di ≈ μ f_h(θ_d, λ)."""
    return np.asarray(mu, float) * _fh(theta_d, lam, fh)


def sg_visibility_product(p, lam, mu, theta_d, *, fh: str = "exact"):
    """Wang09 eq 31: G ⊗ V ≈ G(i; p, λ, μ f_h(θ_d, λ) / f_h(π/2, λ)) → (p, λ, μ')."""
    scale = _fh(theta_d, lam, fh) / fh_hemisphere(lam)
    mu = np.asarray(mu, float)
    if mu.ndim > np.ndim(scale) and np.ndim(scale) > 0:
        scale = scale[..., None]
    return np.asarray(p, float), np.asarray(lam, float), mu * scale


def sample_sg_directions(p, lam, n: int, *, seed: int = 0) -> np.ndarray:
    """n directions distributed ∝ G(i; p, λ) on the whole sphere (stratified √n × √n grid with
    jitter; n rounded down to a square). Inversion: cos θ = 1 + ln(1 − ξ(1 − e^{−2λ}))/λ."""
    m = max(1, int(np.sqrt(n)))
    rng = np.random.default_rng(seed)
    g = (np.arange(m) + 0.0)
    xi1 = ((g[:, None] + rng.random((m, m))) / m).ravel()
    xi2 = ((g[None, :] + rng.random((m, m))) / m).ravel()
    lam = float(lam)
    cos_t = 1.0 + np.log1p(-xi1 * -np.expm1(-2.0 * lam)) / lam
    cos_t = np.clip(cos_t, -1.0, 1.0)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
    phi = 2.0 * np.pi * xi2
    e1, e2, p = polar_frame(p)
    return ((sin_t * np.cos(phi))[:, None] * e1 + (sin_t * np.sin(phi))[:, None] * e2
            + cos_t[:, None] * p)


def sg_total_integral(lam):
    """∫_{S²} e^{λ(i·p − 1)} di = (2π/λ)(1 − e^{−2λ})."""
    lam = np.asarray(lam, float)
    return 2.0 * np.pi * -np.expm1(-2.0 * lam) / lam


def raytraced_sg_visibility(visible_fn, p, lam, mu=1.0, *, n: int = 4096, seed: int = 0):
    """Ground truth ∫ G(i; p, λ, μ) V(i) di by SG importance sampling: μ·∫G·mean(V(i_k)).

    visible_fn: (N, 3) world directions → bool (True = unoccluded and above the surface)."""
    dirs = sample_sg_directions(p, lam, n, seed=seed)
    return float(mu) * float(sg_total_integral(lam)) * float(np.mean(visible_fn(dirs)))
