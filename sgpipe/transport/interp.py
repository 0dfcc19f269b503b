"""Green06 §3.2/§5: interpolation of a vertex's Gaussians across its three nearest views (and the
same blend across a triangle's vertices): the parameters are interpolated — the mean direction
(normalised blend), σ and the RGB weight — never the lobes' values, so a highlight moving
between views moves instead of cross-fading. The OpenCL `transport` method mirrors this."""

from __future__ import annotations

import numpy as np

from sgpipe.transport.views import nearest_views


def blend_gaussians(mu, sigma, w, b):
    """Barycentric blend of corresponding Gaussians: mu (..., 3, K, 3), sigma (..., 3, K),
    w (..., 3, K, 3) with weights b (..., 3) → (mu (..., K, 3) unit, sigma (..., K),
    w (..., K, 3)). Gaussian k blends with Gaussian k (the fit's correspondences):
    μ = normalize(Σ b_i μ_i), σ = Σ b_i σ_i, and w such that the lobe's integral is the blend
    of the integrals, w A(σ) = Σ b_i w_i A(σ_i) (`lobe_area`)."""
    b = np.asarray(b, float)
    m = np.einsum("...i,...ikc->...kc", b, mu)
    norm = np.linalg.norm(m, axis=-1, keepdims=True)
    m = np.where(norm > 0, m / np.where(norm > 0, norm, 1.0), mu[..., 0, :, :])
    s = np.einsum("...i,...ik->...k", b, sigma)
    # the lobes' integrals w A(σ) blend linearly, then the weight is that over A of the blended
    # σ: blending w and σ separately overshoots the integral between a narrow bright lobe and a
    # broad dim one (grazing views: +50 % half way)
    a = np.einsum("...i,...ikc->...kc", b, np.asarray(w) * lobe_area(sigma)[..., None])
    area = lobe_area(s)[..., None]
    return m, s, np.where(area > 0, a / np.where(area > 0, area, 1.0), 0.0)


def lobe_area(sigma):
    """∫ exp((ω·μ − 1)/σ²) dω / 2π = σ² (1 − e^{−2/σ²}) (0 at σ = 0)."""
    s2 = np.asarray(sigma, float) ** 2
    with np.errstate(divide="ignore", over="ignore"):
        return np.where(s2 > 0, s2 * -np.expm1(-2.0 / np.where(s2 > 0, s2, 1.0)), 0.0)


def interpolate_views(mu, sigma, w, q):
    """A vertex's Gaussians (mu (92, K, 3), sigma (92, K), w (92, K, 3)) at view direction(s)
    q (..., 3): blended from the three nearest views with gnomonic barycentric weights."""
    idx, b = nearest_views(q)
    return blend_gaussians(mu[idx], sigma[idx], w[idx], b)


def evaluate(dirs, mu, sigma, w):
    """Σ_k w_k G(ω; μ_k, σ_k) at light directions dirs (M, 3) → (M, 3), G = exp((ω·μ − 1)/σ²)."""
    g = np.exp((np.asarray(dirs) @ np.asarray(mu).T - 1.0) / np.asarray(sigma) ** 2)
    return g @ np.asarray(w)


def crossfade(dirs, mu, sigma, w, q):
    """The linear alternative the paper argues against: the three views' lobes evaluated and
    blended by value (for comparisons)."""
    idx, b = nearest_views(q)
    return sum(b[i] * evaluate(dirs, mu[idx[i]], sigma[idx[i]], w[idx[i]]) for i in range(3))


__all__ = ["blend_gaussians", "lobe_area", "interpolate_views", "evaluate", "crossfade"]
