"""SG ↔ GGX lobe mapping: the GGX prefilter lobe of the split-sum (n = v = r) as a mixture of
normalised SGs (Wang09 eq 2), fitted in L2 over the sphere; roughness ↔ mip level.

The lobe. Engines prefilter an environment for GGX with the "split-sum" assumption n = v = r
(Karis 2013): level(r) = ∫ L(l) D_α(h)(n·l)⁺ dl / ∫ D_α(h)(n·l)⁺ dl, h = normalize(r + l).
With n = v = r the half vector's angle from n is θ/2 (θ = ∠(r, l)), so the kernel is zonal:

    K_α(θ) = D_α(cos(θ/2)) · max(cos θ, 0),   D_α(c) = α² / (π (c²(α² − 1) + 1)²)

(GGX / Trowbridge–Reitz NDF; α = roughness², the glTF / Filament "perceptual" roughness).

The mapping. The Γ_L pyramid gives V(p, λ) = ⟨e^{λ(ω·p − 1)}, L⟩ / S(λ), the radiance averaged
by a normalised SG, for any λ. A normalised GGX lobe K̂_α = K_α / ∫K_α is approximated by
Σ_j w_j e^{λ_j(cos θ − 1)}/S(λ_j) with w_j > 0, Σ w_j = 1 (so a constant map stays constant):
the level is then Σ_j w_j V(r, λ_j). One SG (the classic single-lobe mapping, λ ≈ 0.40/α² for
small α) is 20–23 % off in L2: GGX's θ⁻⁴ tail is not Gaussian; four SGs are ≤ 0.4 % off up to
α = 0.25. Past α ≈ 0.3 no positive SG mixture follows the hemisphere cut-off (α = 1 is the
clamped cosine), and the exporter filters those levels directly (sgpipe.export.prefilter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import least_squares

MIXTURE_LOBES = 4
# the mixture is used where its relative L2 error over the sphere is at most this
MAX_MIXTURE_REL_L2 = 0.01
# small-α shape of the 4-lobe fit (λ_j·α², w_j), measured; the start of every fit
_START_LAM_A2 = np.array([0.03, 0.18, 0.6, 1.7])
_START_W = np.array([0.13, 0.34, 0.40, 0.13])


def roughness_of_level(level: int, levels: int) -> float:
    """The glTF-viewer / Filament-style mip mapping: roughness = level / (levels − 1)."""
    return 0.0 if levels <= 1 else level / (levels - 1)


def alpha_of_roughness(roughness: float) -> float:
    """GGX α = roughness² (perceptual roughness, glTF metallic-roughness)."""
    return float(roughness) ** 2


def ggx_ndf(cos_h, alpha: float):
    """D_α(h) of GGX / Trowbridge–Reitz, normalised so that ∫ D (n·h) dh = 1."""
    a2 = alpha * alpha
    c2 = np.asarray(cos_h, float) ** 2
    return a2 / (np.pi * (c2 * (a2 - 1.0) + 1.0) ** 2)


def ggx_lobe(cos_theta, alpha: float):
    """K_α(θ) = D_α(cos(θ/2)) · max(cos θ, 0), θ = ∠(r, l): the split-sum kernel (unnormalised)."""
    c = np.clip(np.asarray(cos_theta, float), -1.0, 1.0)
    cos_half = np.sqrt(0.5 * (1.0 + c))
    return ggx_ndf(cos_half, alpha) * np.maximum(c, 0.0)


def zonal_nodes(width: float, n: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes θ ∈ [0, π] on panels doubling from width/4 (with an edge at π/2,
    the kink of max(cos θ, 0)), and the weights of the sphere integral of a zonal function
    (2π sin θ dθ folded in)."""
    edges = [0.0]
    e = max(width, 1e-5) / 4.0
    while e < math.pi:
        edges.append(e)
        e *= 2.0
    edges = sorted(set(edges + [0.5 * math.pi, math.pi]))
    x, wx = np.polynomial.legendre.leggauss(n)
    a, b = np.array(edges[:-1])[:, None], np.array(edges[1:])[:, None]
    th = (0.5 * (b - a) * x + 0.5 * (a + b)).ravel()
    w = (0.5 * (b - a) * wx).ravel()
    return th, w * 2.0 * math.pi * np.sin(th)


def sg_normalised(cos_theta, lam):
    """e^{λ(cos θ − 1)} / S(λ), S(λ) = 2π(1 − e^{−2λ})/λ: an SG with unit integral."""
    lam = np.asarray(lam, float)
    return np.exp(lam * (np.asarray(cos_theta, float) - 1.0)) * lam / (
        2.0 * math.pi * -np.expm1(-2.0 * lam))


def ggx_lobe_integral(alpha: float) -> float:
    """∫_S² K_α dω by quadrature (→ 4 as α → 0: D is normalised in h, dl = 4(v·h) dh)."""
    th, w = zonal_nodes(2.0 * alpha)
    return float((ggx_lobe(np.cos(th), alpha) * w).sum())


@dataclass(frozen=True)
class SGMixture:
    """K̂_α ≈ Σ_j weights_j · e^{λ_j(cos θ − 1)}/S(λ_j); rel_l2 = ‖fit − K̂‖/‖K̂‖ over S²."""

    alpha: float
    weights: tuple[float, ...]
    lambdas: tuple[float, ...]
    rel_l2: float

    def __call__(self, cos_theta):
        return sum(w * sg_normalised(cos_theta, lam) for w, lam in zip(self.weights, self.lambdas))


def _softmax(z):
    e = np.exp(z - z.max())
    return e / e.sum()


@lru_cache(maxsize=256)
def fit_sg_mixture(alpha: float, lobes: int = MIXTURE_LOBES) -> SGMixture:
    """The L2-best mixture of `lobes` normalised SGs (weights summing to 1) for the normalised
    GGX lobe of roughness α > 0 (deterministic: a fixed start, Levenberg–Marquardt-like TRF)."""
    if not alpha > 0.0:
        raise ValueError(f"alpha must be > 0, got {alpha}")
    th, w = zonal_nodes(2.0 * alpha)
    ct = np.cos(th)
    k = ggx_lobe(ct, alpha)
    k = k / (k * w).sum()
    scale = np.sqrt(w) / np.sqrt((k * k * w).sum())
    if lobes == MIXTURE_LOBES:
        lam0, w0 = _START_LAM_A2 / alpha ** 2, _START_W
    else:
        lam0 = 0.4 / alpha ** 2 * np.geomspace(0.1, 4.0, lobes) if lobes > 1 else \
            np.array([0.4 / alpha ** 2])
        w0 = np.full(lobes, 1.0 / lobes)
    x0 = np.concatenate([np.log(np.maximum(lam0, 1e-3)), np.log(w0)])

    def residual(x):
        lam, wt = np.exp(x[:lobes]), _softmax(x[lobes:])
        f = (wt[:, None] * sg_normalised(ct[None, :], lam[:, None])).sum(0)
        return (f - k) * scale

    r = least_squares(residual, x0, xtol=1e-12, ftol=1e-12, max_nfev=400)
    lam, wt = np.exp(r.x[:lobes]), _softmax(r.x[lobes:])
    order = np.argsort(lam)
    return SGMixture(float(alpha), tuple(float(v) for v in wt[order]),
                     tuple(float(v) for v in lam[order]),
                     float(np.sqrt((r.fun ** 2).sum())))


def single_sg_sharpness(alpha: float) -> float:
    """The one-SG mapping: the λ whose normalised SG is L2-closest to K̂_α (≈ 0.40/α², α → 0)."""
    return fit_sg_mixture(alpha, 1).lambdas[0]


def lobe_half_width(profile_cos: np.ndarray, values: np.ndarray) -> float:
    """Angle (radians) where a zonal profile, sampled at increasing angle (decreasing cos),
    first falls to half its value at θ = 0 (linear interpolation between samples)."""
    th = np.arccos(np.clip(profile_cos, -1.0, 1.0))
    v = np.asarray(values, float) / float(values[0])
    i = int(np.argmax(v < 0.5))
    if i == 0:
        return float("nan")
    t = (v[i - 1] - 0.5) / (v[i - 1] - v[i])
    return float(th[i - 1] + t * (th[i] - th[i - 1]))
