"""Green06 §6.3 / Fig 5: the relative L2 error of N nonlinear Gaussians against nonlinear Haar
wavelets (the 7N largest coefficients) and spherical harmonics (the smallest full order with at
least 7N coefficients) on three transport functions sampled on a light cube.

Every error is measured in the same metric, √(Σ_j Ω_j (T̃_j − T_j)² / Σ_j Ω_j T_j²) over the
cube's texels (Ω_j the exact texel solid angles), and every approximation is the best of its
kind in that metric: Haar on the cube faces of T √Ω (orthonormal in it, so keeping the largest
coefficients is the optimal nonlinear choice), SH by weighted least squares on the texels,
Gaussians by multi-start nonlinear least squares.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from sgpipe.brdf import make_brdf
from sgpipe.core.sh import sh_eval
from sgpipe.transport.sampling import LightCube, light_cube, vertex_transport

#: the local frame of the figure's surface: normal +Y (the lat-long's pole, CONVENTIONS)
NORMAL, TANGENT, BITANGENT = np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]), \
    np.array([0.0, 0.0, -1.0])


@dataclass(frozen=True)
class LobeCase:
    """One of Fig 5's transport functions: a BRDF × cosine at one view, optionally occluded by a
    cone of half-angle `occluder_deg` about `occluder_axis` (a blocker above the surface)."""

    name: str
    title: str
    model: str
    params: dict
    view_deg: float
    occluder_axis: tuple | None = None
    occluder_deg: float = 0.0


CASES = (
    LobeCase("small_glossy", "small symmetric glossy lobe (Beckmann α 0.1, normal view)",
             "beckmann", {"alpha": 0.1, "kd": 0.0, "ks": 1.0, "fresnel": "none"}, 0.0),
    LobeCase("large_visibility", "large lobe with visibility (GGX α 0.5, view 30°, a 30° "
             "blocker)", "ggx", {"alpha": 0.5, "kd": 0.0, "ks": 1.0, "fresnel": "none"}, 30.0,
             occluder_axis=(-0.45, 0.8, 0.2), occluder_deg=30.0),
    LobeCase("anisotropic_specular", "highly anisotropic specular lobe (Ward α 0.03 × 0.3, "
             "view 45°)", "ward", {"alpha_u": 0.03, "alpha_v": 0.3, "kd": 0.0, "ks": 1.0}, 45.0),
)


def view_dir(deg: float) -> np.ndarray:
    """The view direction `deg` from the normal, tilted towards +X."""
    t = np.radians(deg)
    return np.array([np.sin(t), np.cos(t), 0.0])


def sample_case(case: LobeCase, res: int = 64) -> tuple[LightCube, np.ndarray]:
    """(cube, T (M,)): the scalar transport BRDF × visibility × cosine on a 6×res² cube."""
    cube = light_cube(res)
    vis = cube.dirs @ NORMAL > 0.0
    if case.occluder_axis is not None:
        a = np.asarray(case.occluder_axis, float)
        vis &= cube.dirs @ (a / np.linalg.norm(a)) < np.cos(np.radians(case.occluder_deg))
    brdf = make_brdf(case.model, case.params)
    T, _ = vertex_transport(brdf, NORMAL, TANGENT, BITANGENT, view_dir(case.view_deg)[None],
                            cube, vis)
    return cube, T[0].mean(-1)


def relative_l2(approx, T, omega) -> float:
    """√(Σ Ω (T̃ − T)² / Σ Ω T²)."""
    return float(np.sqrt(np.sum(omega * (approx - T) ** 2) / np.sum(omega * T ** 2)))


# --- Haar ------------------------------------------------------------------------------------
def haar2d(a: np.ndarray) -> np.ndarray:
    """Orthonormal 2D Haar transform (non-standard decomposition) of a 2ⁿ×2ⁿ array: each level
    turns 2×2 blocks into their average and three details, scaled by ½ (an orthonormal map)."""
    a = np.array(a, float)
    n = a.shape[0]
    while n > 1:
        b = a[:n, :n]
        p, q, r, s = b[0::2, 0::2], b[0::2, 1::2], b[1::2, 0::2], b[1::2, 1::2]
        h = n // 2
        out = np.empty((n, n))
        out[:h, :h] = (p + q + r + s) / 2
        out[:h, h:] = (p - q + r - s) / 2
        out[h:, :h] = (p + q - r - s) / 2
        out[h:, h:] = (p - q - r + s) / 2
        a[:n, :n] = out
        n = h
    return a


def ihaar2d(c: np.ndarray) -> np.ndarray:
    """Inverse of `haar2d`."""
    a = np.array(c, float)
    n = 2
    while n <= a.shape[0]:
        h = n // 2
        m, x, y, d = a[:h, :h], a[:h, h:n], a[h:n, :h], a[h:n, h:n]
        out = np.empty((n, n))
        out[0::2, 0::2] = (m + x + y + d) / 2
        out[0::2, 1::2] = (m - x + y - d) / 2
        out[1::2, 0::2] = (m + x - y - d) / 2
        out[1::2, 1::2] = (m - x - y + d) / 2
        a[:n, :n] = out
        n *= 2
    return a


def haar_approx(T, omega, res: int, n_coeffs: int) -> np.ndarray:
    """Nonlinear Haar approximation: the n_coeffs largest of the six faces' Haar coefficients
    of T √Ω (the error metric's orthonormal coordinates), the rest zeroed."""
    sq = np.sqrt(omega).reshape(6, res, res)
    c = np.stack([haar2d(f) for f in T.reshape(6, res, res) * sq])
    keep = np.argsort(np.abs(c).ravel(), kind="stable")[::-1][:n_coeffs]
    kept = np.zeros(c.size)
    kept[keep] = c.ravel()[keep]
    kept = kept.reshape(c.shape)
    return (np.stack([ihaar2d(f) for f in kept]) / sq).ravel()


# --- spherical harmonics ---------------------------------------------------------------------
def sh_order_for(n_coeffs: int) -> int:
    """The smallest l_max whose (l_max + 1)² coefficients are at least n_coeffs."""
    return int(np.ceil(np.sqrt(n_coeffs))) - 1


def sh_approx(T, dirs, omega, lmax: int) -> np.ndarray:
    """The best band-limited (l ≤ lmax) approximation in the texel metric (weighted least
    squares on the texels; equals projection up to the quadrature's error)."""
    Y = sh_eval(dirs, lmax)
    sq = np.sqrt(omega)
    c = np.linalg.lstsq(Y * sq[:, None], T * sq, rcond=None)[0]
    return Y @ c


# --- Gaussians -------------------------------------------------------------------------------
def _mu(theta, phi):
    return np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)],
                    -1)


def gaussians_eval(p, dirs) -> np.ndarray:
    """Σ_k w_k exp((ω·μ_k − 1)/σ_k²) with p = (θ, φ, ln σ, ln w) per Gaussian (μ about +Y)."""
    p = np.asarray(p).reshape(-1, 4)
    mu = _mu(p[:, 0], p[:, 1])
    # ln σ kept within [−8, 3] so that trial steps of the least squares do not overflow
    return np.exp((dirs @ mu.T - 1.0) / np.exp(2 * np.clip(p[:, 2], -8, 3)) + p[:, 3]).sum(-1)


def gaussian_fit(T, dirs, omega, n: int, starts: int = 6):
    """(parameters (n, 4), approximation): n Gaussians with w > 0 by least squares from
    several starts (the data's mean direction and peak, σ over a log grid); further Gaussians
    are added at the largest residual texel of the best fit with one fewer."""
    fits = gaussian_fits(T, dirs, omega, n, starts)
    return fits[-1]


def gaussian_fits(T, dirs, omega, n: int, starts: int = 6, late_starts: int = 2) -> list:
    """[(parameters (k, 4), approximation) for k = 1..n]: the greedy sequence of gaussian_fit
    (each k refits all k Gaussians from the k − 1 fit plus one new start; `late_starts` σ
    starts from k = 4 on, where each fit has 16+ parameters)."""
    sq = np.sqrt(omega)

    def resid(p):
        return sq * (gaussians_eval(p, dirs) - T)

    def start_at(d, val, sig):
        th = np.arccos(np.clip(d[1], -1, 1))
        return [th, np.arctan2(d[2], d[0]), np.log(sig), np.log(max(val, 1e-12))]

    best, prev, out = None, np.zeros((0, 4)), []
    for k in range(1, n + 1):
        base = gaussians_eval(prev, dirs) if len(prev) else np.zeros_like(T)
        r = T - base
        j = int(np.argmax(r))
        m = (np.maximum(r, 0) * omega) @ dirs
        cands = [dirs[j]] + ([m / np.linalg.norm(m)] if np.linalg.norm(m) > 0 else [])
        best = None
        for d in cands:
            for sig in np.geomspace(0.02, 0.8, starts if k <= 3 else late_starts):
                p0 = np.concatenate([prev.ravel(), start_at(d, max(r[j], T.max() * 1e-3), sig)])
                sol = least_squares(resid, p0, method="lm", max_nfev=400 * len(p0))
                if best is None or sol.cost < best.cost:
                    best = sol
        prev = best.x.reshape(-1, 4)
        out.append((prev, gaussians_eval(prev, dirs)))
    return out


def single_gaussian_search(T, dirs, omega, axes_res: int = 16, sigmas: int = 48):
    """(parameters (1, 4), approximation): the best single Gaussian by exhaustive search —
    every texel direction of a 6×axes_res² cube as the axis × `sigmas` σ in [0.02, 2] (log),
    each with its optimal weight w = Σ Ω T g / Σ Ω g² (w ≥ 0) — then least squares from the
    best candidate. Checks that gaussian_fit's one Gaussian is the global optimum."""
    axes = light_cube(axes_res).dirs
    tt = float(np.sum(omega * T * T))
    best = (np.inf, None)
    for sig in np.geomspace(0.02, 2.0, sigmas):
        G = np.exp((dirs @ axes.T - 1.0) / (sig * sig))
        a = (omega * T) @ G
        b = omega @ (G * G)
        err2 = 1.0 - np.where(a > 0, a * a / (b * tt), 0.0)
        k = int(np.argmin(err2))
        if err2[k] < best[0]:
            best = (err2[k], (axes[k], sig, max(a[k] / b[k], 1e-12)))
    d, sig, w = best[1]
    p0 = [np.arccos(np.clip(d[1], -1, 1)), np.arctan2(d[2], d[0]), np.log(sig), np.log(w)]
    sq = np.sqrt(omega)
    sol = least_squares(lambda p: sq * (gaussians_eval(p, dirs) - T), p0, method="lm")
    p = sol.x.reshape(1, 4)
    return p, gaussians_eval(p, dirs)


def case_errors(case: LobeCase, res: int = 64, max_gaussians: int = 3, starts: int = 6) -> dict:
    """Fig 5's numbers for one case: per N = 1..max_gaussians the relative L2 errors of N
    Gaussians, of the 7N largest Haar coefficients and of SH with ≥ 7N coefficients; the
    exhaustive single-Gaussian search's error; and the approximations at N = 1 for the
    figure."""
    cube, T = sample_case(case, res)
    out = {"name": case.name, "title": case.title, "rows": [], "cube": cube, "T": T}
    fits = gaussian_fits(T, cube.dirs, cube.omega, max_gaussians, starts)
    out["single_search"] = relative_l2(single_gaussian_search(T, cube.dirs, cube.omega)[1], T,
                                       cube.omega)
    for n in range(1, max_gaussians + 1):
        budget = 7 * n
        p, g = fits[n - 1]
        h = haar_approx(T, cube.omega, res, budget)
        lmax = sh_order_for(budget)
        s = sh_approx(T, cube.dirs, cube.omega, lmax)
        out["rows"].append({"gaussians": n, "coefficients": budget, "sh_coefficients":
                            (lmax + 1) ** 2, "gaussian": relative_l2(g, T, cube.omega),
                            "haar": relative_l2(h, T, cube.omega),
                            "sh": relative_l2(s, T, cube.omega)})
        if n == 1:
            out["approx"] = {"gaussian": g, "haar": h, "sh": s, "params": p}
    return out


__all__ = ["LobeCase", "CASES", "sample_case", "relative_l2", "haar2d", "ihaar2d",
           "haar_approx", "sh_order_for", "sh_approx", "gaussians_eval", "gaussian_fit",
           "gaussian_fits", "single_gaussian_search", "case_errors"]
