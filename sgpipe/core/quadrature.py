"""Spherical quadrature: Gauss–Legendre in cos θ × uniform φ, optionally about any axis.

A rule with n_theta GL nodes and n_phi uniform azimuths integrates every spherical
polynomial (restriction of a polynomial in x, y, z) of degree <= min(2·n_theta − 1, n_phi − 1)
exactly. ``lobe_quadrature`` grades the polar panels towards the axis for sharp lobes.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

_TWO_PI = 2.0 * np.pi


@lru_cache(maxsize=64)
def _gl(n):
    x, w = np.polynomial.legendre.leggauss(int(n))
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w


def gauss_legendre(n, a=-1.0, b=1.0):
    """n-point Gauss–Legendre nodes and weights on [a, b] (exact for degree 2n − 1)."""
    x, w = _gl(n)
    h = 0.5 * (b - a)
    return a + h * (x + 1.0), h * w


def polar_frame(axis):
    """Orthonormal (e1, e2, axis) with `axis` as polar axis (z ↦ axis)."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    return e1, e2, a


def _product_rule(ct, wt, n_phi, axis):
    phi = (np.arange(n_phi) + 0.5) * (_TWO_PI / n_phi)
    st = np.sqrt(np.maximum(0.0, 1.0 - ct * ct))
    local = np.stack([st[:, None] * np.cos(phi)[None, :],
                      st[:, None] * np.sin(phi)[None, :],
                      np.broadcast_to(ct[:, None], (ct.size, n_phi))], -1).reshape(-1, 3)
    w = (wt[:, None] * np.full(n_phi, _TWO_PI / n_phi)[None, :]).reshape(-1)
    if axis is None:
        return local, w
    e1, e2, a = polar_frame(axis)
    return local[:, :1] * e1 + local[:, 1:2] * e2 + local[:, 2:3] * a, w


def sphere_quadrature(n_theta, n_phi, axis=None):
    """(dirs (N, 3), weights (N,)) on S²; polar axis +Z unless `axis` is given; Σw = 4π."""
    ct, wt = gauss_legendre(n_theta, -1.0, 1.0)
    return _product_rule(ct, wt, int(n_phi), axis)


def hemisphere_quadrature(n_theta, n_phi, axis=None):
    """(dirs, weights) on the hemisphere {d·axis >= 0} (axis +Z by default); Σw = 2π."""
    ct, wt = gauss_legendre(n_theta, 0.0, 1.0)
    return _product_rule(ct, wt, int(n_phi), axis)


def lobe_quadrature(axis, lam, n_per_panel=16, n_phi=64, hemisphere=False):
    """Rule for integrands concentrated in e^{λ(d·axis − 1)}: GL on geometric panels of 1 − cos θ.

    Panel edges in s = 1 − cos θ are 0, s₀, 4s₀, 16s₀, … up to 2 (1 for a hemisphere) with
    s₀ = min(1/λ, 1)/4, so a lobe of any sharpness gets ≥ n_per_panel nodes inside its
    width. φ stays uniform (the lobe is rotationally symmetric about `axis`).
    """
    smax = 1.0 if hemisphere else 2.0
    s0 = min(1.0 / max(float(lam), 1e-12), 1.0) / 4.0
    edges = [0.0]
    s = s0
    while s < smax:
        edges.append(s)
        s *= 4.0
    edges.append(smax)
    cts, wts = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        x, w = gauss_legendre(n_per_panel, a, b)
        cts.append(1.0 - x)
        wts.append(w)
    return _product_rule(np.concatenate(cts), np.concatenate(wts), int(n_phi), axis)


def integrate_sphere(f, n=64, axis=None, lam=None):
    """∫_{S²} f(d) dω for a vectorised f: (N, 3) → (N, ...); lobe-graded if `lam` is given."""
    if lam is None:
        dirs, w = sphere_quadrature(n, 2 * n, axis)
    else:
        dirs, w = lobe_quadrature(axis if axis is not None else (0.0, 0.0, 1.0), lam,
                                  n_per_panel=max(8, n // 4), n_phi=2 * n)
    vals = np.asarray(f(dirs), float)
    return np.tensordot(w, vals, axes=(0, 0))
