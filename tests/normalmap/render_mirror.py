"""Shared pieces of the normal-map kernel tests (tests/normalmap/test_render_*.py): a flat
frame of pixels, a renderer with one normal-mapped object, hand-made pyramids, the closed
forms of nm_shade.h in numpy, and quadrature of a BRDF over a vMF NDF (eq 5)."""

from __future__ import annotations

import math

import numpy as np

from sgpipe.brdf import make_brdf
from sgpipe.normalmap.lobes import rbar_of_kappa
from sgpipe.render.envdata import EnvData
from sgpipe.render.materials import Material, pack_materials
from sgpipe.render.normalmap_data import (BRDF_MODELS, NormalMapData, NormalMapPyramid,
                                          attach_normalmaps)
from sgpipe.render.renderer import Frame, Light, ObjectShading, Renderer
from tests.normalmap.quadrature import frame as axis_frame
from tests.normalmap.quadrature import polar_rule


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def flat_frame(views, uv, duv) -> Frame:
    """Pixels of the plane z = 0 (n = z, t = x) at the origin with the given views (n, 3),
    UVs (n, 2) and UV derivatives (n, 4)."""
    n = len(views)
    f4 = lambda a: np.concatenate([np.asarray(a, float), np.zeros((n, 1))], 1).astype(np.float32)
    return Frame(index=np.arange(n), shape=(n,), normal=f4(np.tile([0, 0, 1.0], (n, 1))),
                 tangent=f4(np.tile([1.0, 0, 0], (n, 1))), view=f4(views),
                 position=f4(np.zeros((n, 3))), uv=np.asarray(uv, np.float32),
                 obj=np.zeros(n, np.int32), tri=np.full(n, -1, np.int32),
                 bary=np.zeros((n, 2), np.float32), duv=np.asarray(duv, np.float32))


def material(model: str, param: float, kd=0.0, ks=1.0, fresnel="none"):
    """(sgpipe.brdf BRDF, Material) of a normal-map material."""
    if model == "lambert":
        params = {"kd": kd}
    elif model == "gltf_pbr":       # a white metal (F0 = 1: F ≡ 1) of GGX α = param
        params = {"base_color": [1.0, 1.0, 1.0], "metallic": 1.0, "roughness": math.sqrt(param)}
    else:
        key = {"blinn_phong": "exponent", "beckmann": "alpha", "cook_torrance": "m",
               "ggx": "alpha"}[model]
        params = {key: param, "kd": kd, "ks": ks, "fresnel": fresnel}
    brdf = make_brdf(model, params)
    m = Material.from_brdf(model, brdf)
    if model in ("ggx", "gltf_pbr"):
        _as_the_pipeline(m, param)
    return brdf, m


def _as_the_pipeline(m, alpha) -> None:
    """A GGX material as the render stage builds it: the roughness grid's NDF lobes at α
    (render.energy.adopt_grid_lobes) and sg's energy table (attach_energy), which the
    normal-map kernels' environment specular reads through sg_lobes_specular."""
    from sgpipe.artifacts.fit import RoughLobes, rough_lobes_at
    from sgpipe.core.ggx_conv import load_lobes
    from sgpipe.render.energy import attach_energy
    grid = load_lobes()
    lam, mu = rough_lobes_at(*grid, alpha)
    m.lobe_axis = np.tile([0.0, 0.0, 1.0], (len(lam), 1))
    m.lobe_lambda, m.lobe_mu = lam, mu
    m.rough_grid = RoughLobes(*grid)
    attach_energy([m])


def renderer(model, param, pyr, *, kd=0.0, ks=1.0, lights=(), env=None, taps=1, rho=None,
             env_sh=None, env_specular=False, fresnel="none", footprint="trilinear", **adds):
    """A Renderer with one object of `model` mapped by `pyr` (NormalMapPyramid or None);
    `adds`: the published variants' `<method>_adds`."""
    _, m = material(model, param, kd, ks, fresnel)
    r = Renderer(env=env or EnvData.constant(0.0), materials=pack_materials([m]),
                 objects=[ObjectShading(0, normal_map=-1)], lights=list(lights), **adds)
    data = NormalMapData.pack([pyr], [param], taps, [BRDF_MODELS[model]], [rho],
                              footprint=footprint)
    attach_normalmaps(r, data.with_environment(env_sh, env_specular))
    return r


def single_lobe_pyramid(mu, kappa, lobes=1, sh=None) -> NormalMapPyramid:
    """Two levels: a 2×2 level 0 (never read at a large footprint) and a 1×1 level 1 holding
    one vMF lobe (μ, κ) — α = 1, α·r with the length whose Banerjee κ is κ — and its exact
    mean A(κ)μ; `sh`: optional γ_lm of the 1×1 level."""
    mu = unit(mu)
    a1 = np.zeros((1, 1, lobes), np.float32)
    ar1 = np.zeros((1, 1, lobes, 3), np.float32)
    a1[0, 0, 0] = 1.0
    ar1[0, 0, 0] = rbar_of_kappa(kappa) * mu
    a_k = 1.0 / math.tanh(kappa) - 1.0 / kappa
    a0 = np.zeros((2, 2, lobes), np.float32)
    a0[..., 0] = 1.0
    ar0 = np.zeros((2, 2, lobes, 3), np.float32)
    ar0[..., 0, :] = mu
    mean = [np.tile(mu, (2, 2, 1)).astype(np.float32),
            (a_k * mu).reshape(1, 1, 3).astype(np.float32)]
    gamma = None
    if sh is not None:
        gamma = [np.zeros((2, 2, len(sh)), np.float32),
                 np.asarray(sh, np.float32).reshape(1, 1, -1)]
    return NormalMapPyramid([a0, a1], [ar0, ar1], mean, gamma)


def vmf_pdf(c, kappa):
    return kappa / (2 * math.pi * (-math.expm1(-2 * kappa))) * np.exp(kappa * (c - 1))


def normal_frames(n):
    """Tangent frames (t, b) of unit normals (N, 3) (isotropic BRDFs: any tangent)."""
    h = np.where(np.abs(n[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    t = unit(h - np.sum(h * n, 1)[:, None] * n)
    return t, np.cross(n, t)


def vmf_quadrature(brdf, mu, kappa, o, i, n_beta=160, n_phi=128) -> np.ndarray:
    """∫ γ_vMF(n; μ, κ) ρ(R_n o, R_n i) max(n·i, 0) dn (eq 5 × cosine), RGB, by Gauss–Legendre
    × trapezoid quadrature over the lobe's cap (β ≤ 12/√κ)."""
    d, w = polar_rule(n_beta, n_phi, min(math.pi, 12 / math.sqrt(kappa)))
    n = d @ axis_frame(mu).T
    t, b = normal_frames(n)
    loc = lambda v: np.stack([t @ v, b @ v, n @ v], -1)  # noqa: E731
    ol, il = loc(np.asarray(o, float)), loc(np.asarray(i, float))
    val = brdf.eval(ol, il) * np.maximum(il[:, 2:3], 0.0)
    val[ol[:, 2] <= 0] = 0.0
    return np.sum(val * (w * vmf_pdf(d[:, 2], kappa))[:, None], 0)


def one_lobe_error(rend, brdf, mu, kappa, views, light, footprint, method="vmf"):
    """Kernel `method` of `rend` (one lobe (μ, κ)) under a directional light, on a flat frame
    of `views` and `footprint`, against ∫ vMF(n) ρ(o, i; n) (n·i) dn per view: (|error| over
    each view's lobe peak (its mirror direction), the quadrature)."""
    img = rend.shade(method, flat_frame(views, np.full((len(views), 2), 0.3), footprint))[:, 0]
    ref = np.array([vmf_quadrature(brdf, mu, kappa, o, light)[0] for o in views])
    peak = np.array([vmf_quadrature(brdf, mu, kappa, o, 2 * (o @ mu) * mu - o)[0]
                     for o in views])
    return np.abs(img - ref) / peak, ref


def g1_beckmann(c, a):
    t = a * a * (1 - c * c) / (c * c)
    if t <= 0:
        return 1.0
    x = 1 / math.sqrt(t)
    if x >= 6:
        return 1.0
    lam = 0.5 * (math.erf(x) - 1) + math.exp(-x * x) / (2 * x * math.sqrt(math.pi))
    return 1 / (1 + lam)


def _ggx_root(c, a):
    return math.sqrt(1 + a * a * (1 - c * c) / (c * c))


def ggx_conv_lobes(alpha, kappa):
    """nm_shade.h nm_ggx_conv_lobes: (λ′, μ′) of GGX's D/4 at α as the roughness grid's SG
    lobes, each convolved with vMF(κ)."""
    from sgpipe.artifacts.fit import rough_lobes_at
    from sgpipe.core.ggx_conv import load_lobes
    lam, mu = rough_lobes_at(*load_lobes(), alpha)
    lc = lam * kappa / (lam + kappa)
    return lc, mu * lc / lam / (4 * math.pi * alpha * alpha)


def microfacet_lobe(model, a, amp, n, o, i, lobes=None):
    """nm_shade.h nm_spec for Beckmann / Cook–Torrance / GGX (separable and height-correlated
    Smith) (F = 1, ks = 1): G·D/(n·o) about n; `lobes` (λ, μ): GGX's D/4 as those SGs."""
    n, o, i = unit(n), unit(o), unit(i)
    ci, co = n @ i, n @ o
    if ci <= 0 or co <= 0:
        return 0.0
    h = unit(o + i)
    ch, oh = n @ h, o @ h
    if model == "beckmann":
        d = math.exp(-(1 - ch * ch) / (ch * ch * a * a)) / (4 * math.pi * a * a * ch ** 4)
        g = g1_beckmann(co, a) * g1_beckmann(ci, a)
    elif model in ("ggx", "gltf_pbr"):
        d = a * a / (4 * math.pi * (ch * ch * (a * a - 1) + 1) ** 2)
        ro, ri = _ggx_root(co, a), _ggx_root(ci, a)
        g = 4 / ((1 + ro) * (1 + ri)) if model == "ggx" else 2 / (ro + ri)
        if lobes is not None:
            d = float(np.sum(lobes[1] * np.exp(lobes[0] * (ch - 1))))
    else:
        d = amp / math.pi * math.exp(-(math.acos(min(ch, 1.0)) / a) ** 2)
        g = min(1.0, 2 * ch * co / oh, 2 * ch * ci / oh)
    return g * d / co


def convolved_roughness(a, kappa):
    """Eq 21 for roughness α = 2σ: (α′, Cook–Torrance amplitude α²/α′²)."""
    a2 = a * a + 2.0 / kappa
    return math.sqrt(a2), a * a / a2


def banerjee_kappa(r):
    return (3 * r - r ** 3) / (1 - r * r)


def directional(i, e=(1.0, 1.0, 1.0)):
    return Light("directional", tuple(unit(i)), tuple(e))


def blinn_lobe(n, o, i, e, norm):
    """nm_shade.h nm_blinn: norm (n·h)^e (n·i), o lifted about n to elevation ≥ asin 0.01."""
    n, o, i = unit(n), unit(o), unit(i)
    ci = n @ i
    if ci <= 0:
        return 0.0
    c = o @ n
    if c < 0.01:
        p = unit(o - c * n)
        o = p * math.sqrt(1 - 1e-4) + 0.01 * n
    h = unit(o + i)
    return norm * max(n @ h, 0.0) ** e * ci


def eq20_lobe(s, kappa):
    """(s′, normalisation) of eq 20 for the material's ks (s+2)/(8π)(n·h)^s."""
    sp = s if kappa > 1e20 else kappa * s / (kappa + s)
    return sp, 0.25 * (s + 2) / (s + 1) * (sp + 1) / (2 * math.pi)
