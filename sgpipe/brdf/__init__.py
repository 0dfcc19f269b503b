"""BRDF models in the local shading frame, their NDFs, M_o(i) factors and importance sampling.

Frame: z = normal n, x = tangent t (`alpha_u`), y = bitangent (`alpha_v`); directions point away
from the surface; arrays of directions have shape (..., 3) and broadcast against each other.

    from sgpipe.brdf import make_brdf, REGISTRY, load_merl
    brdf = make_brdf("ggx", {"alpha": 0.2, "kd": 0.1, "fresnel": "schlick", "f0": 0.04})
    brdf = brdf_from_spec(cfg.fit.materials[0])   # a config material (model, params, merl_file)
    rho = brdf.eval(o, i)                 # ρ(o, i) RGB (..., 3), NO cosine; 0 below horizon
    i, pdf = brdf.sample(o, u1, u2)       # importance sample (diffuse + NDF mixture); pdf in sr⁻¹,
                                          # pdf == 0 marks a failed sample (skip it)
    pdf = brdf.pdf(o, i)                  # density of `sample` at i
    a = brdf.albedo(o)                    # ∫ ρ (n·i) di, RGB (..., 3) (stratified MC)
    d = brdf.ndf(h)                       # peak-normalised D(h) (Wang09 eq 9)
    m = brdf.remaining_factor(o, i)       # M_o(i) = ks g F G2 / (π cos cos), RGB; ρ_s = M·D
    brdf.diffuse(o, i), brdf.specular(o, i), brdf.microfacet_params()   # artifact values
    merl = load_merl("x.binary")          # measured BRDF with the same interface

`sample`/`pdf`/`albedo` take `lobe="all" | "specular" | "diffuse"`.
Models (REGISTRY keys) and parameters (RGB values accept a number or [r, g, b]):
  lambert(kd) · blinn_phong(exponent, kd, ks, fresnel…) · cook_torrance(m, kd, ks, fresnel…)
  ward(alpha | alpha_u+alpha_v, kd, ks) · ashikhmin_shirley(nu, nv, rs, rd, ks)
  beckmann / ggx(alpha | alpha_u+alpha_v, kd, ks, fresnel…)
  gltf_pbr(base_color, metallic, roughness, anisotropy, emissive): glTF 2.0 metal-rough (Appendix B)
  fresnel: none | schlick(f0) | conductor(eta, k) | dielectric(eta)  (Wang09 eq 14)
  merl(merl_file, eta=1.33): MERL table + Wang09 eq 13 tabulated microfacet fit.
Bad parameters raise `BRDFParamError(param, message)` (a ValueError naming the parameter).
"""

from __future__ import annotations

from sgpipe.brdf.base import LUMINANCE, BRDF, half_vector, reflect
from sgpipe.brdf.fresnel import (Fresnel, fresnel_conductor, fresnel_dielectric,
                                 fresnel_schlick)
from sgpipe.brdf.merl import read_merl, synthesize_merl, write_merl
from sgpipe.brdf.models import (BRDFParamError, ashikhmin_shirley, beckmann, blinn_phong,
                                cook_torrance, ggx, gltf_pbr, lambert, ward)
from sgpipe.brdf.tabulated import MerlBRDF, fit_tabulated, load_merl, tabulated_brdf


def _merl(params):
    params = dict(params or {})
    path = params.pop("merl_file", None)
    eta = params.pop("eta", 1.33)
    if path is None:
        raise BRDFParamError("merl_file", "model 'merl' needs merl_file")
    if params:
        k = sorted(params)[0]
        raise BRDFParamError(k, f"unknown parameter {k!r} for model 'merl' (known: eta)")
    if isinstance(eta, bool) or not isinstance(eta, (int, float)) or not eta > 1.0:
        raise BRDFParamError("eta", f"must be a number > 1, got {eta!r}")
    return load_merl(path, eta=float(eta), key="merl_file")


#: model name -> constructor(params: dict) -> BRDF
REGISTRY = {
    "lambert": lambert,
    "blinn_phong": blinn_phong,
    "cook_torrance": cook_torrance,
    "ward": ward,
    "ashikhmin_shirley": ashikhmin_shirley,
    "beckmann": beckmann,
    "ggx": ggx,
    "gltf_pbr": gltf_pbr,
    "merl": _merl,
}


def make_brdf(model: str, params: dict | None = None) -> BRDF:
    """Build a BRDF from the registry; unknown models raise KeyError, bad params BRDFParamError."""
    if model not in REGISTRY:
        raise KeyError(f"unknown BRDF model {model!r} (known: {', '.join(sorted(REGISTRY))})")
    return REGISTRY[model](dict(params or {}))


def brdf_from_spec(spec) -> BRDF:
    """The BRDF of a `fit.materials` entry (its model, params and merl_file): the one way from a
    material spec to a BRDF; errors as make_brdf's."""
    params = dict(spec.params or {})
    if spec.merl_file:
        params["merl_file"] = str(spec.merl_file)
    return make_brdf(spec.model, params)


def frame_rotation(spec) -> float:
    """The angle (radians) a material turns the BRDF's frame by about the shading normal, from
    the tangent towards the bitangent: gltf_pbr's `anisotropy_rotation`, 0 for other models."""
    if spec.model != "gltf_pbr":
        return 0.0
    return float((spec.params or {}).get("anisotropy_rotation", 0.0))


__all__ = ["BRDF", "BRDFParamError", "REGISTRY", "make_brdf", "brdf_from_spec",
           "frame_rotation", "load_merl",
           "MerlBRDF", "read_merl", "write_merl", "synthesize_merl", "fit_tabulated",
           "tabulated_brdf", "Fresnel", "fresnel_schlick", "fresnel_dielectric",
           "fresnel_conductor", "half_vector", "reflect", "LUMINANCE"]
