"""Light representations for diffuse shading: an SG mixture fit (Wang09 §6, < 10 lobes that keep
the bright areas), an SH projection (Green06's fifth-order diffuse), and the exact irradiance
E(n) = ∫ L(ω) max(0, n·ω) dω both are judged against."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from sgpipe.core.maps import cubemap_solid_angles, cubemap_texel_dirs, latlong_texel_dirs
from sgpipe.core.quadrature import lobe_quadrature
from sgpipe.core.sg import CLAMPED_COSINE_LAMBDA, CLAMPED_COSINE_MU, sg_inner
from sgpipe.core.sh import sh_eval, sh_expand_bands, sh_irradiance_coeffs
from sgpipe.envmap._lightfit_jit import (blurred_lobes, clamped_cos_sums, gauss_newton_blocks,
                                         ring_clamped_cos_sums, sg_blur_sums)
from sgpipe.core.maps import cube_mip_chain

_TWO_PI = 2.0 * np.pi


def _chain_masses(chain: list[np.ndarray], res: int):
    """`texel_masses` from an already built MIP chain."""
    lv = next((c for c in chain if c.shape[1] <= res), chain[-1])
    n = lv.shape[1]
    return (cubemap_texel_dirs(n).reshape(-1, 3), cubemap_solid_angles(n).reshape(-1),
            lv.reshape(-1, 3))


def _rows(a: np.ndarray) -> np.ndarray:
    """(M, 3) → contiguous (3, M) for the compiled texel sums."""
    return np.ascontiguousarray(np.asarray(a, float).reshape(-1, 3).T)


def texel_masses(faces: np.ndarray, res: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(dirs (M, 3), solid angles (M,), radiance (M, 3)) of the cubemap box-filtered to `res`."""
    return _chain_masses(cube_mip_chain(faces), res)


def irradiance(dirs: np.ndarray, omega: np.ndarray, radiance: np.ndarray,
               normals: np.ndarray) -> np.ndarray:
    """E(n) = Σ_i L_i Ω_i max(0, n·ω_i) (quadrature over texels) for normals (..., 3)."""
    nrm = np.ascontiguousarray(np.asarray(normals, float).reshape(-1, 3))
    e = np.asarray(radiance, float).reshape(-1, 3) * np.asarray(omega, float).reshape(-1, 1)
    out = clamped_cos_sums(nrm, _rows(dirs), _rows(e))
    return out.reshape(np.shape(normals)[:-1] + (3,))


def irradiance_map(faces: np.ndarray, h: int = 32, w: int = 64, res: int = 64):
    """Exact irradiance as a lat-long map (h, w, 3) (CONVENTIONS mapping of the normal)."""
    d, om, rad = texel_masses(faces, res)
    return irradiance(d, om, rad, latlong_texel_dirs(h, w))


def rel_rms(approx: np.ndarray, ref: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Per-channel relative RMS error sqrt(Σw(a−r)²/Σw r²) → (3,)."""
    a = np.asarray(approx).reshape(-1, 3)
    r = np.asarray(ref).reshape(-1, 3)
    w = np.ones(len(r)) if weights is None else np.asarray(weights).reshape(-1)
    return np.sqrt((w[:, None] * (a - r) ** 2).sum(0) / np.maximum((w[:, None] * r ** 2).sum(0),
                                                                    1e-300))


# --- SH -------------------------------------------------------------------------------------
def sh_light(faces: np.ndarray, lmax: int = 4, res: int = 64) -> dict:
    """SH projection L_k = Σ L Ω Y_k (exact texel solid angles) and the irradiance coefficients
    E_k = Â_l L_k (Ramamoorthi–Hanrahan), basis of `sgpipe.core.sh.sh_eval` on world vectors."""
    d, om, rad = texel_masses(faces, res)
    Y = sh_eval(d, lmax)
    coeffs = (Y * om[:, None]).T @ rad
    irr = coeffs * sh_expand_bands(sh_irradiance_coeffs(lmax))[:, None]
    return {"lmax": np.int32(lmax), "coeffs": coeffs, "irradiance_coeffs": irr}


def sh_irradiance(irr_coeffs: np.ndarray, normals: np.ndarray) -> np.ndarray:
    lmax = int(round(np.sqrt(irr_coeffs.shape[0]))) - 1
    n = np.asarray(normals, float)
    return (sh_eval(n.reshape(-1, 3), lmax) @ irr_coeffs).reshape(n.shape[:-1] + (3,))


# --- SG mixture -----------------------------------------------------------------------------
@dataclass
class SGLight:
    """L*(ω) = Σ_k μ_k e^{λ_k(ω·p_k − 1)} (Wang09 eq 2 lobes; μ in radiance units, RGB)."""

    axes: np.ndarray        # (K, 3)
    sharpness: np.ndarray   # (K,)
    amplitude: np.ndarray   # (K, 3)

    def radiance(self, dirs: np.ndarray) -> np.ndarray:
        d = np.asarray(dirs, float)
        g = np.exp(self.sharpness * (d.reshape(-1, 3) @ self.axes.T - 1.0))
        return (g @ self.amplitude).reshape(d.shape[:-1] + (3,))

    def irradiance_exact(self, normals: np.ndarray, n_per_panel: int = 24) -> np.ndarray:
        """E(n) = Σ_k ∫ G_k(ω) max(0, n·ω) dω: the azimuth about p_k in closed form, cos θ by
        Gauss–Legendre on panels graded about the axis (rel. error ~1e-5 at the terminator kink)."""
        nrm = np.asarray(normals, float).reshape(-1, 3)
        out = np.zeros((len(nrm), 3))
        for p, lam, mu in zip(self.axes, self.sharpness, self.amplitude):
            loc, w = lobe_quadrature(None, lam, n_per_panel=n_per_panel, n_phi=1)   # φ: 1 node
            ct = loc[:, 2]
            st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
            g = (w / _TWO_PI) * np.exp(lam * (ct - 1.0))
            cn = np.clip(nrm @ p, -1.0, 1.0)
            out += ring_clamped_cos_sums(cn, ct, st, g)[:, None] * mu
        return out.reshape(np.shape(normals)[:-1] + (3,))

    def irradiance_sg(self, normals: np.ndarray) -> np.ndarray:
        """Wang09 eq 40 diffuse: Σ_k ⟨G_k, G(·; n, 2.133, 1.170)⟩ (what the SG renderer does)."""
        n = np.asarray(normals, float).reshape(-1, 1, 3)
        v = sg_inner(self.axes[None], self.sharpness[None], 1.0, n, CLAMPED_COSINE_LAMBDA,
                     CLAMPED_COSINE_MU)                                  # (M, K)
        return (v @ self.amplitude).reshape(np.shape(normals)[:-1] + (3,))


def _blur_norm(lam_b: float) -> float:
    """S(λ_b) = ∫ G(·; p, λ_b, 1) = 2π(1 − e^{−2λ_b})/λ_b."""
    return _TWO_PI * (-np.expm1(-2.0 * lam_b)) / lam_b


def _sharpen_small_sources(axes, lam, mu, d, om, rad, lam_min: float, lambda_max: float):
    """λ of lobes sharper than the blur resolves (λ ≥ lam_min), from the unblurred texels.

    Through the λ_b blur a lobe's λ ≫ λ_b barely changes the objective (λλ_b/(λ+λ_b) → λ_b),
    so the fit leaves a small source (a sun) far too broad and its shadows far too soft. An SG
    has E[1 − d·p] = 1/λ (radiance-weighted, λ ≫ 1): measured inside the 3σ cone of the fitted
    lobe, it only ever sharpens (never below the fit); the power μ·2π/λ is kept."""
    lam, mu = lam.copy(), mu.copy()
    w = rad.sum(1) * om
    for j in np.flatnonzero(lam >= lam_min):
        c = d @ axes[j]
        sel = c >= np.cos(min(3.0 / np.sqrt(lam[j]), 0.5))
        m = w[sel].sum()
        if m <= 0.0:
            continue
        var = (w[sel] * (1.0 - c[sel])).sum() / m
        new = min(lambda_max, 1.0 / max(var, 1.0 / lambda_max))
        if new > lam[j]:
            mu[j] *= new / lam[j]
            lam[j] = new
    return lam, mu


class _BlurredFit:
    """Solid-angle weighted L2 fit of the λ_b-blurred map by the blurred mixture (Wang09 eq 4)
    as a separable problem: μ >= 0 is the NNLS optimum for given (axes, ln λ) (variable
    projection), so Levenberg–Marquardt only moves 3 nonlinear parameters per lobe."""

    def __init__(self, q, w, target, blur):
        self.q, self.w, self.t, self.blur = np.ascontiguousarray(q), w, target, blur
        self.sw = np.sqrt(w)
        self.s_b = _blur_norm(blur)

    def eval(self, axes, s):
        """(cost ½Σw r², μ, v, q·p, d, r) at axes (K, 3), s = ln λ (K,)."""
        v, qp, dd = blurred_lobes(self.q, axes, np.exp(s), self.blur, self.s_b)
        A = v * self.sw[:, None]
        mu = np.stack([nnls(A, self.t[:, c] * self.sw)[0] for c in range(3)], 1)
        r = v @ mu - self.t
        return 0.5 * float((self.w[:, None] * r * r).sum()), mu, v, qp, dd, r

    def system(self, axes, s, frames, state):
        """Gauss–Newton gradient and Hessian of the projected cost (Kaufman: the free μ
        eliminated by a Schur complement) in (tangent δ₁, δ₂ of each axis, ln λ)."""
        _, mu, v, qp, dd, r = state
        k = len(s)
        G, R = gauss_newton_blocks(self.q, self.w, r, axes, np.exp(s), frames[0], frames[1],
                                   self.blur, v, qp, dd)
        k3 = 3 * k
        mu3 = np.tile(mu, (3, 1))
        H = G[:k3, :k3] * (mu3 @ mu3.T)
        grad = (R[:k3] * mu3).sum(1)
        for c in range(3):
            free = mu[:, c] > 0.0
            if free.any():
                C = G[:k3, k3:][:, free] * mu3[:, c:c + 1]
                H -= C @ np.linalg.pinv(G[k3:, k3:][np.ix_(free, free)], rcond=1e-13) @ C.T
        return grad, 0.5 * (H + H.T)


def _tangent_frames(axes):
    """(e₁, e₂) ⟂ each axis (K, 3), as `sgpipe.core.quadrature.polar_frame`."""
    helper = np.where((np.abs(axes[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = np.cross(helper, axes)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(axes, e1)


def _solve_lm(prob: _BlurredFit, axes, s, lo, hi, max_iter=200, ftol=1e-4):
    """Projected Levenberg–Marquardt (Nielsen's damping update) on (axes, ln λ ∈ [lo, hi]):
    a ln λ at a bound whose gradient points outwards is held; axes move in their tangent plane
    and are renormalised. Stops after 3 accepted steps in a row that each lower the cost by
    <= ftol (relative), or when no step lowers it."""
    k = len(s)
    state = prob.eval(axes, s)
    damp, nu, small = 1e-3, 2.0, 0
    for _ in range(max_iter):
        frames = _tangent_frames(axes)
        grad, H = prob.system(axes, s, frames, state)
        gs = grad[2 * k:]
        free = np.concatenate([np.ones(2 * k, bool),
                               ~(((s <= lo) & (gs > 0)) | ((s >= hi) & (gs < 0)))])
        diag = np.diag(H)
        if not diag.max() > 0.0 or state[0] <= 0.0:
            break                                     # nothing lit, or an exact fit
        scale = np.maximum(diag, 1e-12 * diag.max())   # Marquardt scaling
        Hf, gf = H[np.ix_(free, free)], grad[free]
        while True:
            step = np.zeros(3 * k)
            try:
                step[free] = np.linalg.solve(Hf + damp * np.diag(scale[free]), -gf)
            except np.linalg.LinAlgError:
                step[:] = 0.0
            new_axes = axes + step[:k, None] * frames[0] + step[k:2 * k, None] * frames[1]
            new_axes /= np.linalg.norm(new_axes, axis=1, keepdims=True)
            new_s = np.clip(s + step[2 * k:], lo, hi)
            new_state = prob.eval(new_axes, new_s)
            gain = state[0] - new_state[0]
            if gain > 0.0:
                sf = step[free]
                pred = -(gf @ sf + 0.5 * sf @ Hf @ sf)
                rho = gain / pred if pred > 0 else 0.0
                damp *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu = 2.0
                axes, s, state = new_axes, new_s, new_state
                small = small + 1 if gain <= ftol * state[0] else 0
                break
            damp *= nu
            nu *= 2.0
            if damp > 1e12:
                return axes, s, state
        if small >= 3:
            break
    return axes, s, state


def _refine(prob: _BlurredFit, axes, s, lam_grid, lo, hi, ftol):
    """`_solve_lm`, then lobes NNLS left unused (μ ≡ 0) re-seeded on the residual and refitted
    while that lowers the cost (at most 3 times)."""
    axes, s, state = _solve_lm(prob, axes, s, lo, hi, ftol=ftol)
    for _ in range(3):
        dead = np.flatnonzero(~(state[1] > 0.0).any(1))
        if not len(dead):
            break
        new_axes, new_s = axes.copy(), s.copy()
        new_axes[dead], new_s[dead] = _greedy_lobes(prob.q, prob.w, -state[5], len(dead),
                                                    lam_grid, prob.blur)
        new = _solve_lm(prob, new_axes, new_s, lo, hi, ftol=ftol)
        if not new[2][0] < state[0]:
            break
        axes, s, state = new
    return axes, s, state


def _greedy_lobes(q, w, resid, n, lam_grid, blur):
    """Tsai–Shih style matching pursuit: n lobes, each at the brightest residual direction with
    the grid λ whose least-squares μ >= 0 removes the most solid-angle weighted L2 error."""
    axes, s = [], []
    resid = resid.copy()
    for _ in range(n):
        p = q[np.argmax(resid.sum(1))]
        g = blurred_lobes(q, np.tile(p, (len(lam_grid), 1)), lam_grid, blur,
                          _blur_norm(blur))[0]                              # (Q, L)
        wg = w[:, None] * g
        num, den = wg.T @ resid, (wg * g).sum(0)                          # (L, 3), (L,)
        # μ = max(num/den, 0) removes Σ_c max(num, 0)²/den of the residual
        i = int(np.argmax((np.maximum(num, 0.0) ** 2).sum(1) / den))
        resid -= g[:, i:i + 1] * np.maximum(num[i] / den[i], 0.0)
        axes.append(p)
        s.append(np.log(lam_grid[i]))
    return np.array(axes), np.array(s)


def fit_sg_light(faces: np.ndarray, n_lobes: int = 8, *, res: int = 16, blur: float = 16.0,
                 lambda_max: float = 4096.0) -> SGLight:
    """Wang09 §6 (after Tsai–Shih): an SG mixture that keeps the bright areas.

    Fitted on the map seen through a normalized SG blur of sharpness `blur` (closed form for
    the mixture, Wang09 eq 4), so a source smaller than a texel keeps its power and direction:
    greedy brightest-first lobes, then a joint least-squares refit of the solid-angle weighted
    L2 error (μ >= 0 by NNLS, λ in [0.5, λ_max]; `_BlurredFit`, `_solve_lm`); lobes sharper
    than the blur resolves get their λ from the texels (`_sharpen_small_sources`)."""
    if not 1 <= n_lobes < 10:
        raise ValueError("n_lobes must be in 1..9")
    chain = cube_mip_chain(faces)
    d, om, rad = _chain_masses(chain, 64)
    q, om_q, _ = _chain_masses(chain, res)
    target = sg_blur_sums(np.ascontiguousarray(q), _rows(d), _rows(rad * om[:, None]), blur)
    target /= _blur_norm(blur)
    prob = _BlurredFit(q, om_q, target, blur)
    lo, hi = np.log(0.5), np.log(lambda_max)
    best = None
    # two greedy starts (the blur cannot tell λ ≫ λ_b apart, so one start stops at 4λ_b), each
    # refined roughly; the better one is then converged
    for lam_top in (lambda_max, min(4.0 * blur, lambda_max)):
        grid = np.geomspace(0.5, lam_top, 28)
        fit = _refine(prob, *_greedy_lobes(q, om_q, target, n_lobes, grid, blur), grid, lo, hi,
                      ftol=1e-3)
        if best is None or fit[2][0] < best[2][0]:
            best = fit
    axes, s, state = _refine(prob, best[0], best[1], np.geomspace(0.5, lambda_max, 28), lo, hi,
                             ftol=1e-4)
    lam, mu = _sharpen_small_sources(axes, np.exp(s), state[1], d, om, rad, 4.0 * blur,
                                     lambda_max)
    order = np.argsort(-(mu.sum(1) / lam), kind="stable")      # most power first
    return SGLight(axes[order], lam[order], mu[order])
