"""Fresnel factors F(c), c = o·h: none, Schlick, conductor (η, k) and dielectric (Wang09 eq 14)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FRESNEL_CODES = {"none": 0, "schlick": 1, "conductor": 2, "dielectric": 3}


def fresnel_schlick(c, f0):
    """Schlick's approximation f0 + (1 − f0)(1 − c)^5; c (...), f0 (3,) -> (..., 3)."""
    c = np.clip(np.asarray(c, float), 0.0, 1.0)[..., None]
    f0 = np.asarray(f0, float)
    return f0 + (1.0 - f0) * (1.0 - c) ** 5


def fresnel_dielectric(c, eta):
    """Wang09 eq 14 (Cook–Torrance): unpolarised dielectric Fresnel, 1 under total reflection."""
    c = np.clip(np.abs(np.asarray(c, float)), 0.0, 1.0)[..., None]
    eta = np.asarray(eta, float)
    g2 = eta * eta + c * c - 1.0
    tir = g2 < 0.0
    g = np.sqrt(np.where(tir, 0.0, g2))
    a = (g - c) ** 2 / (2.0 * np.maximum((g + c) ** 2, 1e-300))
    num = (c * (g + c) - 1.0) ** 2
    den = np.maximum((c * (g - c) + 1.0) ** 2, 1e-300)
    return np.where(tir, 1.0, a * (1.0 + num / den))


def fresnel_conductor(c, eta, k):
    """Exact unpolarised conductor Fresnel with complex index η + ik (pbrt-v3 FrConductor)."""
    c = np.clip(np.abs(np.asarray(c, float)), 0.0, 1.0)[..., None]
    eta = np.asarray(eta, float)
    k = np.asarray(k, float)
    c2 = c * c
    s2 = 1.0 - c2
    t0 = eta * eta - k * k - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * eta * eta * k * k)
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t0), 0.0))
    t1 = a2b2 + c2
    t2 = 2.0 * c * a
    rs = (t1 - t2) / np.maximum(t1 + t2, 1e-300)
    t3 = c2 * a2b2 + s2 * s2
    t4 = t2 * s2
    rp = rs * (t3 - t4) / np.maximum(t3 + t4, 1e-300)
    return 0.5 * (rs + rp)


@dataclass
class Fresnel:
    """A Fresnel choice with its RGB parameters; calling it gives F(c) with shape (..., 3)."""

    kind: str = "none"
    f0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    eta: np.ndarray = field(default_factory=lambda: np.zeros(3))
    k: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __call__(self, c):
        if self.kind == "schlick":
            return fresnel_schlick(c, self.f0)
        if self.kind == "dielectric":
            return fresnel_dielectric(c, self.eta)
        if self.kind == "conductor":
            return fresnel_conductor(c, self.eta, self.k)
        return np.ones(np.shape(c) + (3,))

    @property
    def code(self) -> int:
        return FRESNEL_CODES[self.kind]

    def normal_reflectance(self) -> np.ndarray:
        """F at normal incidence (RGB), used to weight lobe selection when sampling."""
        return np.asarray(self(np.ones(1))[0], float)
