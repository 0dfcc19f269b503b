"""The BRDF class shared by every model: ρ = f_d + M_o(i)·D(h) (Wang09 eq 8–9), sampling, albedo."""

from __future__ import annotations

import numpy as np

from sgpipe.brdf.fresnel import Fresnel, fresnel_schlick
from sgpipe.brdf.ndf import NDF
from sgpipe.brdf.shadowing import Shadowing

DIFFUSE_CODES = {"lambert": 0, "ashikhmin_shirley": 1, "none": 2, "gltf": 3}
#: F0 of the glTF metal-rough dielectric (IOR 1.5) that weights its diffuse by 1 − F(o·h)
GLTF_DIELECTRIC_F0 = 0.04
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _normalize(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def half_vector(o, i):
    """h = (o + i)/‖o + i‖ (zero vector where o = −i)."""
    return _normalize(np.asarray(o, float) + np.asarray(i, float))


def reflect(o, h):
    """Wang09 eq 17: i = ψ(h) = 2(o·h)h − o."""
    return 2.0 * _dot(o, h)[..., None] * h - o


def cosine_sample(u1, u2):
    """Cosine-weighted hemisphere direction (pdf cos θ/π)."""
    r = np.sqrt(np.asarray(u1, float))
    phi = 2.0 * np.pi * np.asarray(u2, float)
    z = np.sqrt(np.maximum(0.0, 1.0 - r * r))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


class BRDF:
    """A BRDF in the local frame (z = n, x = tangent). See `sgpipe.brdf` for the API."""

    def __init__(self, name: str, *, kd=0.0, ks=0.0, diffuse: str = "lambert",
                 ndf: NDF | None = None, fresnel: Fresnel | None = None,
                 shadowing: Shadowing | None = None, g_scale: float = 1.0,
                 params: dict | None = None):
        self.name = name
        self.params = dict(params or {})
        self.kd = np.broadcast_to(np.asarray(kd, float), (3,)).copy()
        self.ks = np.broadcast_to(np.asarray(ks, float), (3,)).copy()
        self.diffuse_kind = diffuse if np.any(self.kd > 0) else "none"
        self.ndf_model = ndf
        self.fresnel = fresnel or Fresnel()
        self.shadowing = shadowing or Shadowing()
        self.g_scale = float(g_scale)
        self.has_specular = ndf is not None and bool(np.any(self.ks > 0))
        self.isotropic = ndf is None or ndf.isotropic
        self._p_spec = self._lobe_probability()

    # -- evaluation ----------------------------------------------------------------------
    def diffuse(self, o, i):
        """Diffuse term f_d(o, i), RGB (..., 3)."""
        o = np.asarray(o, float)
        i = np.asarray(i, float)
        ci, co = i[..., 2], o[..., 2]
        up = (ci > 0) & (co > 0)
        if self.diffuse_kind == "none":
            return np.zeros(np.broadcast_shapes(ci.shape, co.shape) + (3,))
        if self.diffuse_kind == "lambert":
            return np.where(up[..., None], self.kd / np.pi, 0.0)
        if self.diffuse_kind == "gltf":      # glTF 2.0 Appendix B fresnel_mix: (1 − F) c/π
            oh = np.abs(_dot(o, half_vector(o, i)))
            w = 1.0 - fresnel_schlick(oh, GLTF_DIELECTRIC_F0)
            return np.where(up[..., None], self.kd / np.pi * w, 0.0)
        f0 = self.fresnel.f0
        fi = 1.0 - (1.0 - np.maximum(ci, 0.0) / 2.0) ** 5
        fo = 1.0 - (1.0 - np.maximum(co, 0.0) / 2.0) ** 5
        val = (28.0 / (23.0 * np.pi)) * self.kd * (1.0 - f0) * (fi * fo)[..., None]
        return np.where(up[..., None], val, 0.0)

    def ndf(self, h):
        """Peak-normalised NDF D(h) (zeros when the model has no specular lobe)."""
        h = np.asarray(h, float)
        if self.ndf_model is None:
            return np.zeros(h.shape[:-1])
        return self.ndf_model.eval(h)

    def remaining_factor(self, o, i):
        """Wang09 eq 9: M_o(i) = ks g_scale F(o·h) G2(o,i) / (π (n·i)(n·o)), RGB (..., 3)."""
        o = np.asarray(o, float)
        i = np.asarray(i, float)
        h = half_vector(o, i)
        ci, co = i[..., 2], o[..., 2]
        up = (ci > 0) & (co > 0)
        g2 = self.shadowing(o, i, h)
        scale = self.g_scale * g2 / (np.pi * np.where(up, ci * co, 1.0))
        f = self.fresnel(np.abs(_dot(o, h)))
        return np.where(up[..., None], self.ks * f * scale[..., None], 0.0)

    def specular(self, o, i):
        """Specular lobe ks ρ_s = M_o(i) D(h), RGB (..., 3)."""
        if not self.has_specular:
            shape = np.broadcast_shapes(np.shape(o), np.shape(i))
            return np.zeros(shape)
        h = half_vector(o, i)
        return self.remaining_factor(o, i) * self.ndf_model.eval(h)[..., None]

    def eval(self, o, i):
        """ρ(o, i) without the cosine, RGB (..., 3); 0 unless both are above the surface."""
        return self.diffuse(o, i) + self.specular(o, i)

    # -- sampling ------------------------------------------------------------------------
    def _lobe_probability(self) -> float:
        if not self.has_specular:
            return 0.0
        if self.diffuse_kind == "none":
            return 1.0
        rng = np.random.default_rng(12345)
        o = np.array([0.0, 0.0, 1.0])
        u = rng.random((2, 512))
        h = self.ndf_model.sample_h(u[0], u[1])
        i = reflect(o, h)
        pdf = self.ndf_model.pdf_h(h) / (4.0 * np.maximum(_dot(o, h), 1e-12))
        ok = (i[..., 2] > 0) & (pdf > 0)
        val = self.specular(o, i) @ LUMINANCE * np.maximum(i[..., 2], 0)
        e_s = float(np.mean(np.where(ok, val / np.where(ok, pdf, 1.0), 0.0)))
        e_d = float(self.kd @ LUMINANCE)
        if e_s + e_d <= 0:
            return 0.5
        return float(np.clip(e_s / (e_s + e_d), 0.1, 0.9))

    def _p(self, lobe: str) -> float:
        if lobe == "specular":
            return 1.0 if self.has_specular else 0.0
        if lobe == "diffuse":
            return 0.0
        return self._p_spec

    def sample(self, o, u1, u2, lobe: str = "all"):
        """Importance sample i given o: returns (i (..., 3), pdf (...)) with pdf in solid angle.

        `lobe` = "all" (mixture of cosine-weighted diffuse and NDF sampling, h ∝ pdf_h, i = ψ(h)),
        "specular" or "diffuse". Failed samples (reflection below h) have pdf 0.
        """
        o = np.asarray(o, float)
        u1 = np.asarray(u1, float)
        u2 = np.asarray(u2, float)
        shape = np.broadcast_shapes(o.shape[:-1], u1.shape, u2.shape)
        o = np.broadcast_to(o, shape + (3,))
        ps = self._p(lobe)
        use_spec = u1 < ps
        uu = np.where(use_spec, u1 / max(ps, 1e-300), (u1 - ps) / max(1.0 - ps, 1e-300))
        uu = np.clip(uu, 0.0, 1.0 - 1e-16)
        i = cosine_sample(uu, u2)
        if ps > 0:
            h = self.ndf_model.sample_h(uu, u2)
            i = np.where(use_spec[..., None], reflect(o, h), i)
        pdf = self.pdf(o, i, lobe=lobe)
        if ps > 0:
            bad = use_spec & (_dot(o, h) <= 0)
            pdf = np.where(bad, 0.0, pdf)
        return i, pdf

    def pdf(self, o, i, lobe: str = "all"):
        """Solid-angle density of `sample(o, ·, ·, lobe)` at i."""
        o = np.asarray(o, float)
        i = np.asarray(i, float)
        ps = self._p(lobe)
        pd = (1.0 - ps) * np.maximum(i[..., 2], 0.0) / np.pi
        if ps <= 0:
            return pd
        hsum = o + i
        h = _normalize(hsum)
        oh = _dot(o, h)
        ok = (oh > 1e-12) & (h[..., 2] > 0)
        ph = self.ndf_model.pdf_h(h) / (4.0 * np.where(ok, oh, 1.0))
        return pd + ps * np.where(ok, ph, 0.0)

    # -- energy --------------------------------------------------------------------------
    def albedo(self, o, n: int = 64, seed: int = 0, lobe: str = "all"):
        """Directional albedo ∫ ρ(o,i)(n·i) di, RGB (..., 3), by stratified importance sampling
        with n×n strata (deterministic for a seed)."""
        o = np.asarray(o, float)
        rng = np.random.default_rng(seed)
        g = (np.arange(n) + 0.0)[:, None]
        u1 = ((g + rng.random((n, n))) / n).ravel()
        u2 = ((g.T + rng.random((n, n))) / n).ravel()
        ob = o[..., None, :]
        i, pdf = self.sample(ob, u1, u2, lobe=lobe)
        f = self.eval(ob, i) if lobe == "all" else (
            self.specular(ob, i) if lobe == "specular" else self.diffuse(ob, i))
        w = np.where(pdf > 0, np.maximum(i[..., 2], 0.0) / np.where(pdf > 0, pdf, 1.0), 0.0)
        return np.mean(f * w[..., None], axis=-2)

    # -- artifact ------------------------------------------------------------------------
    def microfacet_params(self) -> dict:
        """The values of docs/ARTIFACTS.md `microfacet.npz` (numbers) plus kind names."""
        return {
            "model": self.name,
            "kd": self.kd.copy(), "ks": self.ks.copy() if self.has_specular else np.zeros(3),
            "g_scale": self.g_scale,
            "diffuse": DIFFUSE_CODES[self.diffuse_kind], "diffuse_kind": self.diffuse_kind,
            "fresnel": self.fresnel.code, "fresnel_kind": self.fresnel.kind,
            "f0": self.fresnel.f0.copy(), "eta": self.fresnel.eta.copy(),
            "k": self.fresnel.k.copy(),
            "shadowing": self.shadowing.code, "shadowing_kind": self.shadowing.kind,
            "alpha_u": self.shadowing.au, "alpha_v": self.shadowing.av,
            "shadow_table": self.shadowing.table.copy(),
        }
