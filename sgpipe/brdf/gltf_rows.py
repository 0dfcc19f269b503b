"""The glTF 2.0 metal-rough BRDF (`gltf_pbr`, specification Appendix B) with one parameter set
per row: textured materials, whose base colour, metallic and roughness vary per shading point.

    rows = GltfRows(base (N, 3), metallic (N,), roughness (N,), anisotropy (N,) or scalar)
    rows.eval(o, i); rows.sample(o, u1, u2); rows.pdf(o, i)   # as `BRDF`'s, row k with set k
    rows.take(idx)                                            # the rows idx, for a subset

Row k evaluates exactly as `make_brdf("gltf_pbr", {row k's parameters})` (the tests compare
them row by row); sampling mixes cosine-weighted diffuse and GGX NDF sampling with a per-row
lobe probability.
"""

from __future__ import annotations

import numpy as np

from sgpipe.brdf.base import GLTF_DIELECTRIC_F0, LUMINANCE, cosine_sample, half_vector, reflect
from sgpipe.brdf.fresnel import fresnel_schlick
from sgpipe.brdf.models import GLTF_MIN_ROUGHNESS
from sgpipe.brdf.ndf import GGXNDF
from sgpipe.brdf.shadowing import smith_g2_ggx_correlated


def _dot(a, b):
    return np.sum(a * b, axis=-1)


class GltfRows:
    """Per-row glTF metal-rough parameters; see the module docstring."""

    def __init__(self, base, metallic, roughness, anisotropy=0.0):
        self.base = np.asarray(base, float).reshape(-1, 3)
        n = len(self.base)
        self.metallic = np.broadcast_to(np.asarray(metallic, float), (n,)).copy()
        rough = np.broadcast_to(np.asarray(roughness, float), (n,))
        aniso = np.broadcast_to(np.asarray(anisotropy, float), (n,))
        av = np.maximum(rough, GLTF_MIN_ROUGHNESS) ** 2
        self.ndf = GGXNDF(av + (1.0 - av) * aniso * aniso, av)     # one α pair per row
        m = self.metallic[:, None]
        self.kd = (1.0 - m) * self.base
        self.f0 = (1.0 - m) * GLTF_DIELECTRIC_F0 + m * self.base
        # lobe choice: the specular's normal-incidence share against the diffuse's (any value
        # in (0, 1) is unbiased; rows without diffuse always take the specular lobe)
        ys = (self.f0 + (1.0 - self.f0) / 21.0) @ LUMINANCE     # Schlick's hemispherical mean
        yd = self.kd @ LUMINANCE
        self.p_spec = np.where(yd > 0, np.clip(ys / np.maximum(ys + yd, 1e-300), 0.1, 0.9),
                               1.0)

    def __len__(self) -> int:
        return len(self.base)

    def take(self, idx) -> "GltfRows":
        out = GltfRows.__new__(GltfRows)
        for k in ("base", "metallic", "kd", "f0", "p_spec"):
            setattr(out, k, getattr(self, k)[idx])
        out.ndf = GGXNDF(self.ndf.au[idx], self.ndf.av[idx])
        return out

    # -- evaluation ------------------------------------------------------------------------

    def diffuse(self, o, i):
        """(1 − metallic) c/π (1 − F_0.04(o·h)), (N, 3)."""
        o, i = np.asarray(o, float), np.asarray(i, float)
        up = (o[:, 2] > 0) & (i[:, 2] > 0)
        w = 1.0 - fresnel_schlick(np.abs(_dot(o, half_vector(o, i))), GLTF_DIELECTRIC_F0)
        return np.where(up[:, None], self.kd / np.pi * w, 0.0)

    def specular(self, o, i):
        """F(o·h) G2 D/(4 (n·i)(n·o)) with the height-correlated G2, (N, 3)."""
        o, i = np.asarray(o, float), np.asarray(i, float)
        up = (o[:, 2] > 0) & (i[:, 2] > 0)
        h = half_vector(o, i)
        au, av = self.ndf.au, self.ndf.av
        g2 = smith_g2_ggx_correlated(o, i, au, av)
        d = self.ndf.eval(h) / (np.pi * au * av)
        scale = g2 * d / (4.0 * np.where(up, o[:, 2] * i[:, 2], 1.0))
        f = fresnel_schlick(np.abs(_dot(o, h)), self.f0)
        return np.where(up[:, None], f * scale[:, None], 0.0)

    def eval(self, o, i):
        return self.diffuse(o, i) + self.specular(o, i)

    # -- sampling --------------------------------------------------------------------------
    def sample(self, o, u1, u2):
        """Row k: i drawn from its diffuse/NDF mixture given o; (i (N, 3), pdf (N,)), pdf 0
        marks a failed sample."""
        o = np.asarray(o, float)
        u1, u2 = np.asarray(u1, float), np.asarray(u2, float)
        spec = u1 < self.p_spec
        uu = np.where(spec, u1 / self.p_spec,
                      (u1 - self.p_spec) / np.maximum(1.0 - self.p_spec, 1e-300))
        uu = np.clip(uu, 0.0, 1.0 - 1e-16)
        h = self.ndf.sample_h(uu, u2)
        i = np.where(spec[:, None], reflect(o, h), cosine_sample(uu, u2))
        pdf = self.pdf(o, i)
        return i, np.where(spec & (_dot(o, h) <= 0), 0.0, pdf)

    def pdf(self, o, i):
        o, i = np.asarray(o, float), np.asarray(i, float)
        pd = (1.0 - self.p_spec) * np.maximum(i[:, 2], 0.0) / np.pi
        h = half_vector(o, i)
        oh = _dot(o, h)
        ok = (oh > 1e-12) & (h[:, 2] > 0)
        ph = self.ndf.pdf_h(h)
        return pd + self.p_spec * np.where(ok, ph / (4.0 * np.where(ok, oh, 1.0)), 0.0)
