"""Shadowing/masking kinds G2(o, i) of the remaining factor M_o(i) (Wang09 eq 9–11, 13).

Codes and formulas are the artifact contract of docs/ARTIFACTS.md (`microfacet.npz`).
"""

from __future__ import annotations

import numpy as np
from scipy.special import erf

SHADOWING_CODES = {"none": 0, "implicit": 1, "cook_torrance": 2, "smith_ggx": 3,
                   "smith_beckmann": 4, "ward": 5, "ashikhmin_shirley": 6, "tabulated": 7,
                   "smith_ggx_correlated": 8}

#: Bin centres of tabulated shadowing S(θ): 90 uniform bins over [0, π/2) (Wang09 §4.2).
SHADOW_THETA = (np.arange(90) + 0.5) * (np.pi / 180.0)


def _proj_alpha2(v, au, av):
    """a_v² = α_u² cos²φ_v + α_v² sin²φ_v (projected roughness along v's azimuth)."""
    r2 = v[..., 0] ** 2 + v[..., 1] ** 2
    safe = r2 > 1e-300
    c2 = np.where(safe, v[..., 0] ** 2 / np.where(safe, r2, 1.0), 1.0)
    return au * au * c2 + av * av * (1.0 - c2)


def _tan2(v):
    z2 = np.maximum(v[..., 2] ** 2, 1e-300)
    return np.maximum(1.0 - z2, 0.0) / z2


def smith_g1_ggx(v, au, av):
    """GGX Smith masking G1(v) = 2 / (1 + √(1 + a_v² tan²θ_v))."""
    g = 2.0 / (1.0 + np.sqrt(1.0 + _proj_alpha2(v, au, av) * _tan2(v)))
    return np.where(v[..., 2] > 0, g, 0.0)


def smith_g1_beckmann(v, au, av):
    """Beckmann Smith G1 = 1/(1+Λ), Λ = (erf a − 1)/2 + e^{−a²}/(2a√π), a = 1/(a_v tan θ)."""
    t2 = _tan2(v)
    a = 1.0 / np.sqrt(np.maximum(_proj_alpha2(v, au, av) * t2, 1e-300))
    a_s = np.minimum(a, 30.0)
    lam = 0.5 * (erf(a_s) - 1.0) + np.exp(-a_s * a_s) / (2.0 * a_s * np.sqrt(np.pi))
    lam = np.where(a >= 30.0, 0.0, np.maximum(lam, 0.0))
    return np.where(v[..., 2] > 0, 1.0 / (1.0 + lam), 0.0)


def smith_g2_ggx_correlated(o, i, au, av):
    """Height-correlated GGX Smith G2 = 1/(1 + Λ(o) + Λ(i)), Λ(v) = (√(1 + a_v² tan²θ_v) − 1)/2
    (glTF 2.0 Appendix B's V_GGX = G2/(4 |n·i| |n·o|))."""
    so = np.sqrt(1.0 + _proj_alpha2(o, au, av) * _tan2(o))
    si = np.sqrt(1.0 + _proj_alpha2(i, au, av) * _tan2(i))
    return np.where((o[..., 2] > 0) & (i[..., 2] > 0), 2.0 / (so + si), 0.0)


class Shadowing:
    """G2(o, i) of one kind (see SHADOWING_CODES); `table` is S(θ) on SHADOW_THETA (kind 7)."""

    def __init__(self, kind: str = "none", alpha_u: float = 0.0, alpha_v: float = 0.0,
                 table=None):
        if kind not in SHADOWING_CODES:
            raise ValueError(f"unknown shadowing kind {kind!r}")
        self.kind = kind
        self.au = float(alpha_u)
        self.av = float(alpha_v if alpha_v else alpha_u)
        self.table = np.ones(90) if table is None else np.asarray(table, float)

    @property
    def code(self) -> int:
        return SHADOWING_CODES[self.kind]

    def s_tab(self, v):
        """The table linear between bin centres and from the last one to S(π/2) = 0 (every
        microfacet surface's masking ends at grazing; microfacet.h shadow_table)."""
        th = np.arccos(np.clip(v[..., 2], -1.0, 1.0))
        return np.where(v[..., 2] > 0, np.interp(th, np.append(SHADOW_THETA, np.pi / 2),
                                                 np.append(self.table, 0.0)), 0.0)

    def __call__(self, o, i, h):
        ci = np.maximum(i[..., 2], 0.0)
        co = np.maximum(o[..., 2], 0.0)
        k = self.kind
        if k == "none":
            return np.ones(np.broadcast_shapes(ci.shape, co.shape))
        if k == "implicit":
            return ci * co
        if k == "cook_torrance":
            oh = np.maximum(np.sum(o * h, axis=-1), 1e-300)
            nh = h[..., 2]
            return np.minimum(1.0, np.minimum(2.0 * nh * co / oh, 2.0 * nh * ci / oh))
        if k == "smith_ggx":
            return smith_g1_ggx(o, self.au, self.av) * smith_g1_ggx(i, self.au, self.av)
        if k == "smith_ggx_correlated":
            return smith_g2_ggx_correlated(o, i, self.au, self.av)
        if k == "smith_beckmann":
            return smith_g1_beckmann(o, self.au, self.av) * smith_g1_beckmann(i, self.au, self.av)
        if k == "ward":
            return np.sqrt(ci * co)
        if k == "ashikhmin_shirley":
            oh = np.maximum(np.sum(o * h, axis=-1), 1e-300)
            return ci * co / (oh * np.maximum(np.maximum(ci, co), 1e-300))
        return self.s_tab(o) * self.s_tab(i)
