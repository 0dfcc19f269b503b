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


def truth_levels(normals: np.ndarray, s: float, h: np.ndarray, n_levels: int) -> list:
    """Per level the texel mean of f_s(ω_h · n_i) over its covered normals."""
    out = [_lobe(normals @ h, s)]
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
