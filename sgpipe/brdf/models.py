"""Parametric models (Lambert, Blinn–Phong, Cook–Torrance, Ward, Ashikhmin–Shirley, Beckmann,
GGX) as `BRDF` instances in the common form ρ = f_d + ks g F G2 D/(π cos cos) (Wang09 eq 9)."""

from __future__ import annotations

import numpy as np

from sgpipe.brdf.base import BRDF
from sgpipe.brdf.fresnel import Fresnel
from sgpipe.brdf.ndf import (AshikhminShirleyNDF, BeckmannNDF, BlinnNDF, CookTorranceNDF,
                             GGXNDF, WardNDF)
from sgpipe.brdf.shadowing import Shadowing


class BRDFParamError(ValueError):
    """A model parameter is unknown, missing or out of range; `param` names it."""

    def __init__(self, param: str, message: str):
        super().__init__(message)
        self.param = param
        self.message = message


class _Params:
    """Validated access to a params mapping; remembers which keys were used."""

    def __init__(self, model: str, params: dict):
        self.model = model
        self.raw = dict(params or {})
        self.used: set[str] = set()

    def number(self, key, default=None, *, gt=None, ge=None, le=None):
        self.used.add(key)
        v = self.raw.get(key, default)
        if v is None:
            raise BRDFParamError(key, f"model {self.model!r} needs parameter {key!r}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
            raise BRDFParamError(key, f"expected a finite number, got {v!r}")
        self._bounds(key, float(v), gt, ge, le)
        return float(v)

    def rgb(self, key, default, *, ge=0.0, le=None):
        self.used.add(key)
        v = self.raw.get(key, default)
        vals = v if isinstance(v, (list, tuple)) else [v]
        if len(vals) not in (1, 3) or any(isinstance(x, bool) or not isinstance(x, (int, float))
                                          or not np.isfinite(x) for x in vals):
            raise BRDFParamError(key, f"expected a number or [r, g, b], got {v!r}")
        for x in vals:
            self._bounds(key, float(x), None, ge, le)
        return np.broadcast_to(np.asarray(vals, float), (3,)).copy()

    def choice(self, key, default, choices):
        self.used.add(key)
        v = self.raw.get(key, default)
        if v not in choices:
            raise BRDFParamError(key, f"must be one of {', '.join(choices)}, got {v!r}")
        return v

    def has(self, key):
        return key in self.raw

    @staticmethod
    def _bounds(key, v, gt, ge, le):
        if gt is not None and not v > gt:
            raise BRDFParamError(key, f"must be > {gt}, got {v}")
        if ge is not None and not v >= ge:
            raise BRDFParamError(key, f"must be >= {ge}, got {v}")
        if le is not None and not v <= le:
            raise BRDFParamError(key, f"must be <= {le}, got {v}")

    def finish(self):
        unknown = sorted(set(self.raw) - self.used)
        if unknown:
            raise BRDFParamError(unknown[0], f"unknown parameter {unknown[0]!r} for model "
                                 f"{self.model!r} (known: {', '.join(sorted(self.used))})")
        return self.raw


def _fresnel(p: _Params, default: str = "none", f0: float = 0.04, eta: float = 1.5) -> Fresnel:
    kind = p.choice("fresnel", default, ("none", "schlick", "conductor", "dielectric"))
    fr = Fresnel(kind)
    if kind == "schlick" or p.has("f0"):
        fr.f0 = p.rgb("f0", f0, ge=0.0, le=1.0)
    if kind in ("dielectric", "conductor") or p.has("eta"):
        fr.eta = p.rgb("eta", eta if kind != "conductor" else 0.2, ge=1e-3)
        if np.any(fr.eta <= 0):
            raise BRDFParamError("eta", "must be > 0")
    if kind == "conductor" or p.has("k"):
        fr.k = p.rgb("k", 3.0, ge=0.0)
    return fr


def _alphas(p: _Params):
    """alpha (isotropic) or alpha_u / alpha_v (anisotropic), each in (0, 1]."""
    if p.has("alpha_u") or p.has("alpha_v"):
        if p.has("alpha"):
            raise BRDFParamError("alpha", "give either alpha or alpha_u/alpha_v, not both")
        au = p.number("alpha_u", gt=0.0, le=1.0)
        av = p.number("alpha_v", gt=0.0, le=1.0)
        return au, av
    a = p.number("alpha", 0.1, gt=0.0, le=1.0)
    return a, a


def lambert(params):
    """Lambert: ρ = kd/π."""
    p = _Params("lambert", params)
    kd = p.rgb("kd", 0.8, le=1.0)
    p.finish()
    return BRDF("lambert", kd=kd, params=params)


def blinn_phong(params):
    """Normalised Blinn–Phong ρ_s = ks (n+2)/(8π) (n·h)^n: D = (n·h)^n, G2 implicit, g = (n+2)/8."""
    p = _Params("blinn_phong", params)
    e = p.number("exponent", 100.0, gt=0.0, le=1e6)
    kd, ks = p.rgb("kd", 0.0, le=1.0), p.rgb("ks", 1.0)
    fr = _fresnel(p)
    p.finish()
    return BRDF("blinn_phong", kd=kd, ks=ks, ndf=BlinnNDF(e), fresnel=fr,
                shadowing=Shadowing("implicit"), g_scale=(e + 2.0) / 8.0, params=params)


def cook_torrance(params):
    """Wang09 eq 10–11: ρ_s = F S_CT D/(π (n·i)(n·o)), D = exp(−(θ_h/m)²), V-cavity S_CT."""
    p = _Params("cook_torrance", params)
    m = p.number("m", 0.2, gt=0.0, le=1.0)
    kd, ks = p.rgb("kd", 0.0, le=1.0), p.rgb("ks", 1.0)
    fr = _fresnel(p, "dielectric")
    p.finish()
    return BRDF("cook_torrance", kd=kd, ks=ks, ndf=CookTorranceNDF(m), fresnel=fr,
                shadowing=Shadowing("cook_torrance", m, m), g_scale=1.0, params=params)


def ward(params):
    """Ward (`alpha` or `alpha_u`/`alpha_v`): ρ_s = ks e^{−tan²θ_h(..)}/(4π α_u α_v √(cos cos))."""
    p = _Params("ward", params)
    au, av = _alphas(p)
    kd, ks = p.rgb("kd", 0.0, le=1.0), p.rgb("ks", 1.0)
    fr = _fresnel(p)
    p.finish()
    return BRDF("ward", kd=kd, ks=ks, ndf=WardNDF(au, av), fresnel=fr,
                shadowing=Shadowing("ward", au, av), g_scale=1.0 / (4.0 * au * av),
                params=params)


def ashikhmin_shirley(params):
    """Ashikhmin–Shirley 2000: anisotropic Phong lobe (Schlick F, f0 = `rs`) + diffuse `rd`."""
    p = _Params("ashikhmin_shirley", params)
    nu = p.number("nu", 100.0, gt=0.0, le=1e6)
    nv = p.number("nv", nu, gt=0.0, le=1e6)
    rs = p.rgb("rs", 0.05, le=1.0)
    rd = p.rgb("rd", 0.0, le=1.0)
    ks = p.rgb("ks", 1.0)
    p.finish()
    fr = Fresnel("schlick", f0=rs)
    return BRDF("ashikhmin_shirley", kd=rd, ks=ks, diffuse="ashikhmin_shirley",
                ndf=AshikhminShirleyNDF(nu, nv), fresnel=fr,
                shadowing=Shadowing("ashikhmin_shirley"),
                g_scale=np.sqrt((nu + 1.0) * (nv + 1.0)) / 8.0, params=params)


def _smith_model(name, ndf_cls, kind):
    def make(params):
        p = _Params(name, params)
        au, av = _alphas(p)
        kd, ks = p.rgb("kd", 0.0, le=1.0), p.rgb("ks", 1.0)
        fr = _fresnel(p, "schlick")
        p.finish()
        return BRDF(name, kd=kd, ks=ks, ndf=ndf_cls(au, av), fresnel=fr,
                    shadowing=Shadowing(kind, au, av), g_scale=1.0 / (4.0 * au * av),
                    params=params)
    make.__doc__ = (f"{name} microfacet (`alpha` or `alpha_u`/`alpha_v`, separable Smith "
                    f"shadowing): ρ_s = ks F G1 G1 D/(4 (n·i)(n·o)).")
    return make


beckmann = _smith_model("beckmann", BeckmannNDF, "smith_beckmann")
ggx = _smith_model("ggx", GGXNDF, "smith_ggx")


#: Smallest GGX α of `gltf_pbr` (roughness 0.06): a glTF roughness of 0 is a perfect mirror,
#: which no lobe fit, sampler or tabulated NDF holds; at α 0.0036 the NDF's SG fit is still
#: within 0.3 % relative L2 (below it the fit fails), and the lobe is far narrower than a texel
#: of any environment sgpipe prefilters.
GLTF_MIN_ROUGHNESS = 0.06


def gltf_pbr(params):
    """glTF 2.0 metal-rough BRDF (specification Appendix B): mix(dielectric, metal, metallic)
    = (1 − m)(1 − F_0.04(o·h)) c/π + F(o·h) V_GGX D_GGX, F Schlick with F0 = lerp(0.04, c, m),
    α = max(roughness, GLTF_MIN_ROUGHNESS)², V height-correlated Smith;
    KHR_materials_anisotropy's strength s widens α along the tangent to lerp(α, 1, s²);
    `anisotropy_rotation` (its anisotropyRotation, radians) turns that direction about the
    shading normal from the tangent towards the bitangent (the renderers' frame, not the BRDF:
    the BRDF here is in that turned frame).
    `emissive` (RGB radiance, default 0) is the surface's emission: not part of the BRDF, the
    renderers add it where they see the surface."""
    from sgpipe.brdf.base import GLTF_DIELECTRIC_F0
    p = _Params("gltf_pbr", params)
    base = p.rgb("base_color", 1.0, le=1.0)
    metallic = p.number("metallic", 1.0, ge=0.0, le=1.0)
    rough = p.number("roughness", 1.0, ge=0.0, le=1.0)
    aniso = p.number("anisotropy", 0.0, ge=0.0, le=1.0)
    p.number("anisotropy_rotation", 0.0)
    p.rgb("emissive", 0.0)
    p.finish()
    av = max(rough, GLTF_MIN_ROUGHNESS) ** 2
    au = av + (1.0 - av) * aniso * aniso
    f0 = (1.0 - metallic) * GLTF_DIELECTRIC_F0 + metallic * base
    return BRDF("gltf_pbr", kd=(1.0 - metallic) * base, ks=1.0, diffuse="gltf",
                ndf=GGXNDF(au, av), fresnel=Fresnel("schlick", f0=f0),
                shadowing=Shadowing("smith_ggx_correlated", au, av),
                g_scale=1.0 / (4.0 * au * av), params=params)
