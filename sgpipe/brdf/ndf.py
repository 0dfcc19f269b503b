"""Peak-normalised microfacet NDFs D(h) (D(n) = 1) with exact sampling of h (Wang09 eq 9–12).

Local frame: z = normal, x = tangent (alpha_u), y = bitangent (alpha_v). Every NDF exposes
`eval(h)`, `sample_h(u1, u2) -> h`, `pdf_h(h)` (solid-angle density of `sample_h`, which need not
be proportional to D: Cook–Torrance and Ward are sampled with Beckmann's density), `isotropic`
and `sg_analytic()` -> (λ, μ) of a single SG lobe about +z matching D's peak curvature in
(1 − h·n) (Wang09 eq 12 for Cook–Torrance), or None where no such lobe exists.
"""

from __future__ import annotations

import math

import numpy as np

_TWO_PI = 2.0 * np.pi


def _cos_phi2(h):
    """(cos²φ_h, sin²φ_h) of a direction, (1, 0) at the pole."""
    r2 = h[..., 0] ** 2 + h[..., 1] ** 2
    safe = r2 > 1e-300
    c2 = np.where(safe, h[..., 0] ** 2 / np.where(safe, r2, 1.0), 1.0)
    return c2, 1.0 - c2


def _from_polar(cos_t, phi):
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=-1)


def _aniso_phi(u1, ru, rv):
    """φ with tan φ = (rv/ru) tan(2π u1) in the right quadrant (exact for elliptic slopes)."""
    t = _TWO_PI * np.asarray(u1, float)
    return np.arctan2(rv * np.sin(t), ru * np.cos(t))


class NDF:
    """Base class; see the module docstring."""

    isotropic = True
    name = "ndf"

    def eval(self, h):
        raise NotImplementedError

    def sample_h(self, u1, u2):
        raise NotImplementedError

    def pdf_h(self, h):
        raise NotImplementedError

    def sg_analytic(self):
        return None

    def width(self) -> float:
        """Rough angular width (radians) of the lobe, used to size quadrature grids."""
        return 0.5


class BeckmannNDF(NDF):
    """Beckmann: D = exp(−tan²θ (cos²φ/α_u² + sin²φ/α_v²)) / cos⁴θ (= π α_u α_v D_Beckmann)."""

    name = "beckmann"

    def __init__(self, alpha_u, alpha_v=None):
        self.au = float(alpha_u)
        self.av = float(alpha_u if alpha_v is None else alpha_v)
        self.isotropic = self.au == self.av

    def _exponent(self, h):
        z2 = np.maximum(h[..., 2] ** 2, 1e-300)
        return (h[..., 0] ** 2 / self.au**2 + h[..., 1] ** 2 / self.av**2) / z2

    def eval(self, h):
        h = np.asarray(h, float)
        z = h[..., 2]
        pos = z > 0
        zs = np.where(pos, z, 1.0)
        val = np.exp(-np.minimum(self._exponent(h), 700.0)) / zs**4
        return np.where(pos, val, 0.0)

    def sample_h(self, u1, u2):
        phi = _aniso_phi(u1, self.au, self.av)
        c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
        tan2 = -np.log1p(-np.minimum(np.asarray(u2, float), 1.0 - 1e-16)) / (
            c2 / self.au**2 + s2 / self.av**2)
        cos_t = 1.0 / np.sqrt(1.0 + tan2)
        return _from_polar(cos_t, phi)

    def pdf_h(self, h):
        """D_Beckmann(h) cos θ_h (normalised over the hemisphere)."""
        h = np.asarray(h, float)
        z = h[..., 2]
        return np.where(z > 0, BeckmannNDF.eval(self, h) * np.maximum(z, 0.0)
                        / (np.pi * self.au * self.av), 0.0)

    def sg_analytic(self):
        lam = 2.0 / self.au**2 - 4.0   # ln D ≈ −(2/α² − 4)(1 − c)
        return (lam, 1.0) if self.isotropic and lam > 0 else None

    def width(self):
        return max(self.au, self.av)


class WardNDF(BeckmannNDF):
    """Ward: D = exp(−tan²θ (cos²φ/α_u² + sin²φ/α_v²)); sampled with Beckmann's density."""

    name = "ward"

    def eval(self, h):
        h = np.asarray(h, float)
        pos = h[..., 2] > 0
        return np.where(pos, np.exp(-np.minimum(self._exponent(h), 700.0)), 0.0)

    def sg_analytic(self):
        return (2.0 / self.au**2, 1.0) if self.isotropic else None  # tan²θ ≈ 2(1 − c)


class GGXNDF(NDF):
    """GGX / Trowbridge–Reitz: D = 1/(x²/α_u² + y²/α_v² + z²)² (= π α_u α_v D_GGX)."""

    name = "ggx"

    def __init__(self, alpha_u, alpha_v=None):
        # a material's roughness, or one per row (N,) of h / u arrays (N, ...): textured
        # roughness (sgpipe.brdf.gltf_rows)
        def alpha(a):
            return float(a) if np.ndim(a) == 0 else np.asarray(a, float)
        self.au = alpha(alpha_u)
        self.av = alpha(alpha_u if alpha_v is None else alpha_v)
        self.isotropic = bool(np.all(self.au == self.av))

    def eval(self, h):
        h = np.asarray(h, float)
        q = h[..., 0] ** 2 / self.au**2 + h[..., 1] ** 2 / self.av**2 + h[..., 2] ** 2
        return np.where(h[..., 2] > 0, 1.0 / np.maximum(q, 1e-300) ** 2, 0.0)

    def sample_h(self, u1, u2):
        phi = _aniso_phi(u1, self.au, self.av)
        c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
        u2 = np.minimum(np.asarray(u2, float), 1.0 - 1e-16)
        tan2 = u2 / ((1.0 - u2) * (c2 / self.au**2 + s2 / self.av**2))
        return _from_polar(1.0 / np.sqrt(1.0 + tan2), phi)

    def pdf_h(self, h):
        h = np.asarray(h, float)
        return np.where(h[..., 2] > 0, self.eval(h) * np.maximum(h[..., 2], 0.0)
                        / (np.pi * self.au * self.av), 0.0)

    def sg_analytic(self):
        lam = 4.0 * (1.0 / self.au**2 - 1.0)   # ln D ≈ −4(1/α² − 1)(1 − c)
        return (lam, 1.0) if self.isotropic and lam > 0 else None

    def width(self):
        return max(self.au, self.av)


class CookTorranceNDF(NDF):
    """Wang09 eq 11: D = exp(−(θ_h/m)²); sampled with Beckmann's density of roughness m."""

    name = "cook_torrance"

    def __init__(self, m):
        self.m = float(m)
        self._prop = BeckmannNDF(m)

    def eval(self, h):
        h = np.asarray(h, float)
        z = h[..., 2]
        th = np.arccos(np.clip(z, -1.0, 1.0))
        return np.where(z > 0, np.exp(-(th / self.m) ** 2), 0.0)

    def sample_h(self, u1, u2):
        return self._prop.sample_h(u1, u2)

    def pdf_h(self, h):
        return self._prop.pdf_h(h)

    def sg_analytic(self):
        return 2.0 / self.m**2, 1.0   # Wang09 eq 12

    def width(self):
        return self.m


class BlinnNDF(NDF):
    """Blinn–Phong: D = (n·h)^e; pdf_h = (e+2)/(2π) cos^{e+1} θ_h (exact)."""

    name = "blinn_phong"

    def __init__(self, exponent):
        self.e = float(exponent)

    def eval(self, h):
        z = np.asarray(h, float)[..., 2]
        return np.where(z > 0, np.maximum(z, 0.0) ** self.e, 0.0)

    def sample_h(self, u1, u2):
        cos_t = np.asarray(u2, float) ** (1.0 / (self.e + 2.0))
        return _from_polar(cos_t, _TWO_PI * np.asarray(u1, float))

    def pdf_h(self, h):
        z = np.maximum(np.asarray(h, float)[..., 2], 0.0)
        return (self.e + 2.0) / _TWO_PI * z ** (self.e + 1.0)

    def sg_analytic(self):
        return self.e, 1.0   # ln cos θ ≈ −(1 − c)

    def width(self):
        return float(np.sqrt(2.0 / (self.e + 2.0)))


class AshikhminShirleyNDF(NDF):
    """Ashikhmin–Shirley: D = (n·h)^{(n_u cos²φ + n_v sin²φ)}; their sampling has the exact
    density pdf_h = √((n_u+1)(n_v+1))/(2π) D(h) (the φ map tan φ = a tan(πu/2) integrates out)."""

    name = "ashikhmin_shirley"

    def __init__(self, nu, nv):
        self.nu = float(nu)
        self.nv = float(nv)
        self.isotropic = self.nu == self.nv

    def _exp(self, h):
        c2, s2 = _cos_phi2(h)
        return self.nu * c2 + self.nv * s2

    def eval(self, h):
        h = np.asarray(h, float)
        z = h[..., 2]
        return np.where(z > 0, np.maximum(z, 1e-300) ** self._exp(h), 0.0)

    def sample_h(self, u1, u2):
        a = np.sqrt((self.nu + 1.0) / (self.nv + 1.0))
        phi = _aniso_phi(u1, 1.0, a)
        e = self.nu * np.cos(phi) ** 2 + self.nv * np.sin(phi) ** 2
        cos_t = (1.0 - np.asarray(u2, float)) ** (1.0 / (e + 1.0))
        return _from_polar(cos_t, phi)

    def pdf_h(self, h):
        return np.sqrt((self.nu + 1.0) * (self.nv + 1.0)) / _TWO_PI * self.eval(h)

    def sg_analytic(self):
        return (self.nu, 1.0) if self.isotropic else None

    def width(self):
        return float(np.sqrt(2.0 / (min(self.nu, self.nv) + 2.0)))


class TabulatedNDF(NDF):
    """Isotropic tabulated D(θ_h) (Wang09 §4.2) on MERL's θ_h bins, piecewise-linear in θ_h;
    sampled from the piecewise-constant density D cos θ_h over the bins."""

    name = "tabulated"

    def __init__(self, theta, values):
        self.theta = np.asarray(theta, float)
        self.values = np.maximum(np.asarray(values, float), 0.0)
        edges = np.concatenate([[0.0], 0.5 * (self.theta[1:] + self.theta[:-1]), [np.pi / 2]])
        self.edges = edges
        cos_e = np.cos(edges)
        mass = self.values * np.cos(self.theta) * (cos_e[:-1] - cos_e[1:]) * _TWO_PI
        mass = np.maximum(mass, 1e-12 * max(mass.max(), 1e-300))
        self.bin_p = mass / mass.sum()
        self.cdf = np.concatenate([[0.0], np.cumsum(self.bin_p)])
        self.dcos = cos_e[:-1] - cos_e[1:]

    def eval(self, h):
        h = np.asarray(h, float)
        th = np.arccos(np.clip(h[..., 2], -1.0, 1.0))
        return np.where(h[..., 2] > 0, np.interp(th, self.theta, self.values), 0.0)

    def sample_h(self, u1, u2):
        u2 = np.asarray(u2, float)
        b = np.clip(np.searchsorted(self.cdf, u2, side="right") - 1, 0, len(self.bin_p) - 1)
        t = (u2 - self.cdf[b]) / self.bin_p[b]
        cos_hi = np.cos(self.edges[b])
        cos_t = cos_hi - np.clip(t, 0.0, 1.0) * self.dcos[b]
        return _from_polar(cos_t, _TWO_PI * np.asarray(u1, float))

    def pdf_h(self, h):
        h = np.asarray(h, float)
        th = np.arccos(np.clip(h[..., 2], -1.0, 1.0))
        b = np.clip(np.searchsorted(self.edges, th, side="right") - 1, 0, len(self.bin_p) - 1)
        return np.where(h[..., 2] > 0, self.bin_p[b] / (_TWO_PI * self.dcos[b]), 0.0)

    def width(self):
        half = self.values >= 0.5 * self.values.max()
        return float(max(self.theta[half].max(), 0.01))


def beckmann_ndf(u, alpha: float) -> np.ndarray:
    """Beckmann D(θ_h) = e^{−tan²θ/α²}/(πα² cos⁴θ) on the upper hemisphere (∫ D cos dω = 1)."""
    u = np.asarray(u, float)
    pos = u > 1e-8
    us = np.where(pos, u, 1.0)
    t2 = (1.0 - us * us) / (us * us)
    return np.where(pos, np.exp(-np.minimum(t2 / alpha ** 2, 700.0))
                    / (math.pi * alpha ** 2 * us ** 4), 0.0)
