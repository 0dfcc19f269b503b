"""Texel-level accuracy of the filtered pyramids: the Blinn–Phong lobe f_s(ω_h · n) averaged over
the normals a texel covers (the exact effective BRDF of Han07 eq 4 for one light and view)
against what each method reconstructs from its level: the vMF mixture through eq 20, the SH
NDF through eq 12, Toksvig's exponent f·s and the normalised MIP. No rendering: a per-level
check of the precompute and the source of the stage's previews."""

from __future__ import annotations

import math

import numpy as np

from sgpipe.core.sh import sh_eval, sh_expand_bands
from sgpipe.normalmap.pyramid import box_down, normalized_mip, toksvig_factor
from sgpipe.normalmap.sh import blinn_phong_coeffs


def half_vector(light_deg: tuple[float, float]) -> np.ndarray:
    """ω_h for a light at (elevation, azimuth) degrees in the tangent frame, viewer along +z."""
    el, az = np.radians(light_deg[0]), np.radians(light_deg[1])
    wi = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    h = wi + np.array([0.0, 0.0, 1.0])
    return h / np.linalg.norm(h)


def _lobe(cos, s):
    """(s + 1)/(2π) max(cos, 0)^s with per-texel exponents s."""
    return (s + 1.0) / (2.0 * math.pi) * np.maximum(cos, 0.0) ** s


def truth_samples(normals: np.ndarray, s: float, h: np.ndarray) -> np.ndarray:
    """f_s(ω_h · n) per normal: what `truth_levels` averages."""
    return _lobe(normals @ h, s)


def truth_levels(normals: np.ndarray, s: float, h: np.ndarray, n_levels: int) -> list:
    """Per level the texel mean of f_s(ω_h · n_i) over its covered normals."""
    out = [truth_samples(normals, s, h)]
    for _ in range(1, n_levels):
        out.append(box_down(out[-1]))
    return out


def vmf_level(alpha: np.ndarray, alpha_r: np.ndarray, s: float, h: np.ndarray) -> np.ndarray:
    """Σ_j α_j f_{s′_j}(ω_h · μ_j), s′ = κs/(κ + s) (eq 20) from the stored textures."""
    a = alpha.astype(np.float64)
    ar = alpha_r.astype(np.float64)
    r = ar / np.maximum(a, 1e-30)[..., None]
    rl = np.minimum(np.linalg.norm(r, axis=-1), 1.0 - 1e-12)
    kappa = (3.0 * rl - rl ** 3) / (1.0 - rl * rl)
    mu = r / np.maximum(rl, 1e-30)[..., None]
    sp = kappa * s / np.maximum(kappa + s, 1e-30)
    val = np.where(a > 0, a * _lobe(mu @ h, sp), 0.0)
    return val.sum(axis=-1)


def sh_level(gamma: np.ndarray, s: float, h: np.ndarray) -> np.ndarray:
    """Eq 12 with the normalised Blinn–Phong ρ̂_l up to the stored order."""
    k = gamma.shape[-1]
    lmax = int(round(math.sqrt(k))) - 1
    w = sh_expand_bands(blinn_phong_coeffs(s, lmax)) * sh_eval(h, lmax)
    return gamma.astype(np.float64) @ w


def baseline_levels(mean: np.ndarray, s: float, h: np.ndarray) -> tuple:
    """(Toksvig, normalised MIP) shading of one level's mean normals."""
    n = normalized_mip(mean.astype(np.float64))
    ft = toksvig_factor(mean.astype(np.float64), s)
    return _lobe(n @ h, ft * s), _lobe(n @ h, s)


def rel_rms(x: np.ndarray, ref: np.ndarray) -> float:
    """√(mean (x − ref)²) / √(mean ref²)."""
    return float(np.sqrt(np.mean((x - ref) ** 2) / max(np.mean(ref ** 2), 1e-300)))


# -- one texel's NDF against its vMF mixture (Han07 Fig 7) --------------------------------------

def ndf_sh(normals: np.ndarray, lmax: int) -> np.ndarray:
    """γ_lm of a texel's NDF γ = (1/N) Σ δ(n − n_i) (eq 9): the mean of Y_lm(n_i), ((lmax+1)²,)."""
    return sh_eval(np.asarray(normals, np.float64).reshape(-1, 3), lmax).mean(axis=0)


def mixture_sh(alpha, mu, kappa, lmax: int) -> np.ndarray:
    """γ_lm of Σ_j α_j vMF(μ_j, κ_j): by Funk–Hecke α_j g_l(κ_j) Y_lm(μ_j), with the exact vMF
    zonal coefficients g_l = i_l(κ)/i_0(κ) (eq 15; lobes.vmf_zonal_exact)."""
    from sgpipe.normalmap.lobes import vmf_zonal_exact
    out = np.zeros((lmax + 1) ** 2)
    for a, m, k in zip(alpha, mu, kappa):
        if a > 0 and k > 0:
            g = sh_expand_bands(vmf_zonal_exact(float(k), lmax))
            out += a * g * sh_eval(np.asarray(m, np.float64)[None], lmax)[0]
    return out


def ndf_sh_error(normals: np.ndarray, alpha, mu, kappa, lmax: int = 8) -> float:
    """Relative L2 error on the sphere of the mixture's NDF against the texel's, both band-limited
    to l ≤ lmax (Parseval: the norm of the SH coefficient difference)."""
    g = ndf_sh(normals, lmax)
    return float(np.linalg.norm(mixture_sh(alpha, mu, kappa, lmax) - g) / np.linalg.norm(g))


def lit_sphere_half_vectors(size: int, light_deg: tuple[float, float]):
    """A sphere seen by an orthographic viewer along +z (towards the viewer), lit by a
    directional light at (polar angle from +z, azimuth) degrees: per pixel on the disc the half vector in the local
    tangent frame (t = x̂ projected, b = n × t) and cos(n, light); (mask, h_local (P, 3), cos)."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, -c)
    mask = x * x + y * y < 1.0
    n = np.stack([x[mask], y[mask], np.sqrt(1.0 - x[mask] ** 2 - y[mask] ** 2)], -1)
    th, az = np.radians(light_deg[0]), np.radians(light_deg[1])
    li = np.array([math.sin(th) * math.cos(az), math.sin(th) * math.sin(az), math.cos(th)])
    h = li + np.array([0.0, 0.0, 1.0])
    h /= np.linalg.norm(h)
    t = np.array([1.0, 0.0, 0.0]) - n[:, :1] * n
    t /= np.linalg.norm(t, axis=-1, keepdims=True)
    b = np.cross(n, t)
    h_loc = np.stack([t @ h, b @ h, n @ h], -1)
    return mask, h_loc, np.maximum(n @ li, 0.0)


def texel_blinn_phong(normals: np.ndarray, s: float, h_local: np.ndarray) -> np.ndarray:
    """The exact effective Blinn–Phong lobe of a texel (eq 4): the mean of f_s(ω_h · n_i) over its
    normals (duplicates merged, so that large texels stay cheap)."""
    u, cnt = np.unique(np.asarray(normals, np.float64).reshape(-1, 3), axis=0,
                       return_counts=True)
    return _lobe(np.asarray(h_local) @ u.T, s) @ (cnt / cnt.sum())
