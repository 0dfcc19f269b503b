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
    w (..., K, 3)). Gaussian k blends with Gaussian k (the fit's correspondences)."""
    b = np.asarray(b, float)
    m = np.einsum("...i,...ikc->...kc", b, mu)
    norm = np.linalg.norm(m, axis=-1, keepdims=True)
    m = np.where(norm > 0, m / np.where(norm > 0, norm, 1.0), mu[..., 0, :, :])
    return m, np.einsum("...i,...ik->...k", b, sigma), np.einsum("...i,...ikc->...kc", b, w)


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


__all__ = ["blend_gaussians", "interpolate_views", "evaluate", "crossfade"]
