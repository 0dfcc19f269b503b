"""Reference decoder of the visibility artifacts: SSDF at world directions (docs/ARTIFACTS.md).

The OpenCL renderer ports exactly these steps; tests compare against them.
"""

from __future__ import annotations

import numpy as np

from sgpipe.core.sphere import hemisphere_to_concentric_square


def bilinear(images: np.ndarray, u, v) -> np.ndarray:
    """Bilinear fetch of (K, R, R) images at (u, v) ∈ [0,1]² (u along columns), texel centres
    at (i + 0.5)/R, clamp-to-edge → (..., K)."""
    images = np.asarray(images)
    res = images.shape[-1]
    x = np.asarray(u, float) * res - 0.5
    y = np.asarray(v, float) * res - 0.5
    x0 = np.floor(x)
    y0 = np.floor(y)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    xi0 = np.clip(x0, 0, res - 1).astype(np.intp)
    xi1 = np.clip(x0 + 1, 0, res - 1).astype(np.intp)
    yi0 = np.clip(y0, 0, res - 1).astype(np.intp)
    yi1 = np.clip(y0 + 1, 0, res - 1).astype(np.intp)
    img = np.moveaxis(images, 0, -1)          # (R, R, K)
    top = img[yi0, xi0] * (1 - fx) + img[yi0, xi1] * fx
    bot = img[yi1, xi0] * (1 - fx) + img[yi1, xi1] * fx
    return top * (1 - fy) + bot * fy


def _orthonormal_frame(n, t):
    n = np.asarray(n, float)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    t = np.asarray(t, float)
    t = t - np.sum(t * n, axis=-1, keepdims=True) * n
    t = t / np.linalg.norm(t, axis=-1, keepdims=True)
    return n, t, np.cross(n, t)


def decode_ssdf_local(local, coeffs, mean, basis, *, max_distance=np.pi / 2) -> np.ndarray:
    """SSDF at local directions ℓ (..., 3) (z = normal) of vertices with PCA `coeffs` (..., N).

    Steps 2–4 of the ARTIFACTS decoder: bilinear PCA reconstruction on the concentric image
    for ℓ_z ≥ 0; below the horizon S = min(S_horizon, 0) − asin(−ℓ_z); clamp."""
    local = np.asarray(local, float)
    coeffs = np.asarray(coeffs, float)
    images = np.concatenate([np.asarray(mean, float)[None], np.asarray(basis, float)], axis=0)
    lz = local[..., 2]
    below = lz < 0.0
    h = local.copy()
    h[..., 2] = np.where(below, 0.0, lz)
    rho = np.hypot(h[..., 0], h[..., 1])
    pole = below & (rho < 1e-12)                 # ℓ = −n: any horizon point; S_h := 0
    h[..., 0] = np.where(pole, 1.0, h[..., 0])
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    u, v = hemisphere_to_concentric_square(h)
    w = np.concatenate([np.ones(coeffs.shape[:-1] + (1,)), coeffs], axis=-1)
    s = np.sum(bilinear(images, u, v) * w, axis=-1)
    s_h = np.where(pole, 0.0, s)
    s = np.where(below, np.minimum(s_h, 0.0) - np.arcsin(np.clip(-lz, 0.0, 1.0)), s)
    return np.clip(s, -max_distance, max_distance)


def decode_ssdf(w, coeffs, mean, basis, normal, tangent, *, max_distance=np.pi / 2
                ) -> np.ndarray:
    """SSDF θ_d at world directions w (..., 3) for vertices/pixels with PCA `coeffs` (..., N)
    and frame (normal, tangent) (re-orthonormalised; b = n × t). Broadcasts."""
    n, t, b = _orthonormal_frame(normal, tangent)
    w = np.asarray(w, float)
    local = np.stack([np.sum(w * t, -1), np.sum(w * b, -1), np.sum(w * n, -1)], axis=-1)
    return decode_ssdf_local(local, coeffs, mean, basis, max_distance=max_distance)


def decode_ssdf_image(image, local, *, max_distance=np.pi / 2) -> np.ndarray:
    """The same decoder for one uncompressed (R, R) SSDF image (e.g. before PCA)."""
    return decode_ssdf_local(local, np.zeros(0), image, np.zeros((0,) + np.shape(image)),
                             max_distance=max_distance)
