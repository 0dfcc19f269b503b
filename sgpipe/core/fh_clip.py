"""The visible part of an SG cut by the hemisphere visibility model (Wang09 eq 30) as one SG.

Wang09 eq 31 approximates G ⊗ V by G with its amplitude scaled by f̂_h(θ_d, λ): the lobe keeps
its axis and sharpness, so a lobe whose axis lies near or behind the boundary (a rim, or the
tangent plane for a rough lobe seen at a grazing angle) reads its light from behind the
boundary; a broad lobe (λ ≲ 2) reads it from the whole sphere. Here the clipped lobe
G·1[ω·q ≥ 0] (axis p, p·q = sin θ_d, as in core.fh) is replaced by the SG

    A · exp(λ'(ω·p' − 1)),   p' = p turned towards q by δ,   A ∫G' = f_h(θ_d, λ),

whose integral is eq 31's (so energy is unchanged) and whose (δ, λ') minimise the L2 distance
‖G·1 − A G'‖² over the sphere. Every term is a 1-D integral: ∫ A²G'² is an SG integral, and
⟨G·1, G'⟩ = e^{κ−λ−λ'} f_h(asin(u·q), κ) for the product lobe (κ u = λ p + λ' p'), so each fit
is a small 2-parameter minimisation of exact integrals (`clip_fit`). `clip_table` tabulates
(δ √λ, ln(λ'/λ)) on θ_d × ln λ for the kernels (render.headers); sharper lobes than the table
use the planar limit, the truncated Gaussian's moments (`planar_clip`).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from .fh import fh_exact
from .sg import sg_integral

#: the table's grid: columns u = θ_d √λ_c on [−CLIP_U, CLIP_U] with λ_c = max(λ, CLIP_LAMC)
#: (so broad lobes span θ_d ∈ [−π/2, π/2] and sharp ones ±CLIP_U σ), rows ln λ on
#: [ln CLIP_LAMMIN, ln CLIP_LAMMAX] (beyond: the nearest row, the planar limit by then)
CLIP_U, CLIP_NT, CLIP_NL, CLIP_LAMMIN, CLIP_LAMMAX = 6.0, 97, 48, 0.05, 1.0e4
CLIP_LAMC = (2.0 * CLIP_U / np.pi) ** 2
#: the stored table (`python -m sgpipe.core.fh_clip` writes it)
TABLE_PATH = __import__("pathlib").Path(__file__).with_name("fh_clip_table.npz")


def table_grid() -> tuple[np.ndarray, np.ndarray]:
    """(θ_d (CLIP_NL, CLIP_NT), λ (CLIP_NL,)) at the table's nodes."""
    u = np.linspace(-CLIP_U, CLIP_U, CLIP_NT)
    lams = np.exp(np.linspace(np.log(CLIP_LAMMIN), np.log(CLIP_LAMMAX), CLIP_NL))
    th = np.clip(u[None, :] / np.sqrt(np.maximum(lams, CLIP_LAMC))[:, None], -np.pi / 2,
                 np.pi / 2)
    return th, lams


def l2_objective(theta_d, lam, delta, lam2):
    """‖G·1[ω·q ≥ 0] − A G'‖² / ‖G·1[ω·q ≥ 0]‖² (the relative squared L2 error) for the
    unit-amplitude SG (p, λ) with p·q = sin θ_d and the SG (p', λ'), p' at elevation θ_d + δ
    in the plane of p and q, A = f_h(θ_d, λ)/∫G'."""
    th2 = theta_d + delta
    p = np.array([np.cos(theta_d), 0.0, np.sin(theta_d)])
    p2 = np.array([np.cos(th2), 0.0, np.sin(th2)])
    v = lam * p + lam2 * p2
    kappa = float(np.linalg.norm(v))
    el = float(np.arcsin(np.clip(v[2] / kappa, -1.0, 1.0)))
    cross = np.exp(kappa - lam - lam2) * fh_exact(el, kappa)
    a = fh_exact(theta_d, lam) / sg_integral(lam2, 1.0)
    norm = fh_exact(theta_d, 2.0 * lam)                   # ∫_{ω·q ≥ 0} G², G² = SG of 2λ
    return float(1.0 + (a * a * sg_integral(2.0 * lam2, 1.0) - 2.0 * a * cross) / norm)


def planar_clip(theta_d, lam):
    """(δ √λ, ln(λ'/λ)) of the planar limit: the Gaussian of variance 1/λ truncated at distance
    θ_d from its centre, its mean (shift δ = σ r, r = φ(a)/Φ(a), a = θ_d √λ) and its variance
    across the boundary (1 − a r − r²)/λ."""
    from scipy.special import log_ndtr
    a = np.maximum(np.asarray(theta_d, float) * np.sqrt(np.asarray(lam, float)), -30.0)
    r = np.exp(-0.5 * a * a - 0.5 * np.log(2.0 * np.pi) - log_ndtr(a))
    var = np.clip(1.0 - a * r - r * r, 1e-6, 1.0)
    return r, -np.log(var)


def clip_fit(theta_d: float, lam: float, start=None) -> tuple[float, float]:
    """(δ √λ, ln(λ'/λ)) of the L2-closest SG with eq 31's integral (module docstring);
    `start`: a guess in the same units (default: the planar limit)."""
    if start is None:
        start = tuple(float(x) for x in planar_clip(theta_d, lam))
    sq = np.sqrt(lam)
    # p' stays on the visible side's half of the great circle through p and q
    hi = (np.pi / 2 - theta_d) * sq
    x0 = np.array([min(max(start[0], 0.0), hi), start[1]])
    res = minimize(lambda x: l2_objective(theta_d, lam, x[0] / sq, lam * np.exp(x[1])), x0,
                   method="L-BFGS-B", bounds=[(0.0, hi), (-3.0, 8.0)],
                   options={"ftol": 1e-12, "gtol": 1e-9})
    return float(res.x[0]), float(res.x[1])


def clip_table() -> np.ndarray:
    """(CLIP_NL, CLIP_NT, 2) of (δ √λ, ln(λ'/λ)) at `table_grid`'s nodes, each fit started from
    its neighbour's towards the hidden side (the table is smooth for bilinear lookups)."""
    th, lams = table_grid()
    out = np.zeros((CLIP_NL, CLIP_NT, 2))
    for i, lam in enumerate(lams):
        prev = None
        for j in range(CLIP_NT - 1, -1, -1):       # from the visible side, where δ → 0
            prev = clip_fit(th[i, j], lam, prev)
            out[i, j] = prev
    return out


def load_table() -> np.ndarray:
    """The stored table (`clip_table`'s values)."""
    with np.load(TABLE_PATH, allow_pickle=False) as z:
        return z["table"]


if __name__ == "__main__":
    np.savez_compressed(TABLE_PATH, table=clip_table())
    print(f"wrote {TABLE_PATH}")
