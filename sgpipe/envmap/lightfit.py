"""Light representations for diffuse shading: an SG mixture fit (Wang09 §6, < 10 lobes that keep
the bright areas), an SH projection (Green06's fifth-order diffuse), and the exact irradiance
E(n) = ∫ L(ω) max(0, n·ω) dω both are judged against."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from sgpipe.core.maps import cubemap_solid_angles, cubemap_texel_dirs, latlong_texel_dirs
from sgpipe.core.quadrature import lobe_quadrature
from sgpipe.core.sg import CLAMPED_COSINE_LAMBDA, CLAMPED_COSINE_MU, sg_inner
from sgpipe.core.sh import sh_eval, sh_expand_bands, sh_irradiance_coeffs
from sgpipe.envmap.mip import cube_mip_chain


def texel_masses(faces: np.ndarray, res: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(dirs (M, 3), solid angles (M,), radiance (M, 3)) of the cubemap box-filtered to `res`."""
    chain = cube_mip_chain(faces)
    lv = next((c for c in chain if c.shape[1] <= res), chain[-1])
    n = lv.shape[1]
    return (cubemap_texel_dirs(n).reshape(-1, 3), cubemap_solid_angles(n).reshape(-1),
            lv.reshape(-1, 3))


def irradiance(dirs: np.ndarray, omega: np.ndarray, radiance: np.ndarray,
               normals: np.ndarray) -> np.ndarray:
    """E(n) = Σ_i L_i Ω_i max(0, n·ω_i) (quadrature over texels) for normals (..., 3)."""
    nrm = np.asarray(normals, float).reshape(-1, 3)
    e = radiance * omega[:, None]
    out = np.empty((len(nrm), 3))
    for a in range(0, len(nrm), 256):
        out[a:a + 256] = np.maximum(nrm[a:a + 256] @ dirs.T, 0.0) @ e
    return out.reshape(np.shape(normals)[:-1] + (3,))


def irradiance_map(faces: np.ndarray, h: int = 32, w: int = 64, res: int = 64):
    """Exact irradiance as a lat-long map (h, w, 3) (GUIDE mapping of the normal)."""
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

    def irradiance_exact(self, normals: np.ndarray) -> np.ndarray:
        """E(n) = Σ_k ∫ G_k(ω) max(0, n·ω) dω, each lobe by a quadrature graded about its axis."""
        nrm = np.asarray(normals, float).reshape(-1, 3)
        out = np.zeros((len(nrm), 3))
        for p, lam, mu in zip(self.axes, self.sharpness, self.amplitude):
            dirs, w = lobe_quadrature(p, lam, n_per_panel=12, n_phi=48)
            g = w * np.exp(lam * (dirs @ p - 1.0))
            out += (np.maximum(nrm @ dirs.T, 0.0) @ g)[:, None] * mu
        return out.reshape(np.shape(normals)[:-1] + (3,))

    def irradiance_sg(self, normals: np.ndarray) -> np.ndarray:
        """Wang09 eq 40 diffuse: Σ_k ⟨G_k, G(·; n, 2.133, 1.170)⟩ (what the SG renderer does)."""
        n = np.asarray(normals, float).reshape(-1, 1, 3)
        v = sg_inner(self.axes[None], self.sharpness[None], 1.0, n, CLAMPED_COSINE_LAMBDA,
                     CLAMPED_COSINE_MU)                                  # (M, K)
        return (v @ self.amplitude).reshape(np.shape(normals)[:-1] + (3,))


def _unpack(x: np.ndarray, k: int):
    x = x.reshape(k, 7)
    axes = x[:, :3] / np.linalg.norm(x[:, :3], axis=1, keepdims=True)
    return axes, np.exp(x[:, 3]), x[:, 4:]


def _blurred_model(q: np.ndarray, axes, lam, mu, lam_b: float) -> np.ndarray:
    """Σ_k ⟨G_k, G(·; q, λ_b, 1)⟩ / S(λ_b): the mixture seen through a normalized SG blur."""
    v = sg_inner(axes[None], lam[None], 1.0, q[:, None], lam_b, 1.0)      # (Q, K)
    s_b = 2.0 * np.pi * (1.0 - np.exp(-2.0 * lam_b)) / lam_b
    return v @ mu / s_b


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


def fit_sg_light(faces: np.ndarray, n_lobes: int = 8, *, res: int = 16, blur: float = 16.0,
                 lambda_max: float = 4096.0) -> SGLight:
    """Wang09 §6 (after Tsai–Shih): an SG mixture that keeps the bright areas.

    Fitted on the map seen through a normalized SG blur of sharpness `blur` (closed form for
    the mixture, Wang09 eq 4), so a source smaller than a texel keeps its power and direction:
    greedy brightest-first lobes, then a joint least-squares refit of the solid-angle weighted
    L2 error (μ >= 0, λ in [0.5, λ_max])."""
    if not 1 <= n_lobes < 10:
        raise ValueError("n_lobes must be in 1..9")
    d, om, rad = texel_masses(faces, 64)
    q, om_q, _ = texel_masses(faces, res)
    e = rad * om[:, None]
    target = np.empty((len(q), 3))
    s_b = 2.0 * np.pi * (1.0 - np.exp(-2.0 * blur)) / blur
    for a in range(0, len(q), 512):
        target[a:a + 512] = np.exp(blur * (q[a:a + 512] @ d.T - 1.0)) @ e / s_b
    sw = np.sqrt(om_q)[:, None]
    lam_grid = np.geomspace(0.5, lambda_max, 28)
    x = np.zeros((0, 7))
    resid = target.copy()
    for _ in range(n_lobes):
        p = q[np.argmax(resid.sum(1))]
        best = None
        for lam in lam_grid:
            g = _blurred_model(q, p[None], np.array([lam]), np.ones((1, 1)), blur)[:, 0]
            mu = np.maximum((om_q[:, None] * g[:, None] * resid).sum(0) / (om_q * g * g).sum(),
                            0.0)
            err = (om_q[:, None] * (resid - g[:, None] * mu) ** 2).sum()
            if best is None or err < best[0]:
                best = (err, lam, mu, g)
        _, lam, mu, g = best
        resid = resid - g[:, None] * mu
        x = np.vstack([x, np.concatenate([p, [np.log(lam)], mu])])
    k = n_lobes
    lo = np.tile([-2, -2, -2, np.log(0.5), 0, 0, 0], k).astype(float)
    hi = np.tile([2, 2, 2, np.log(lambda_max), np.inf, np.inf, np.inf], k).astype(float)
    x0 = np.clip(x.ravel(), lo + 1e-9, hi - 1e-9)

    def parts(xx):
        xr = xx.reshape(k, 7)
        nx = np.linalg.norm(xr[:, :3], axis=1)
        axes = xr[:, :3] / nx[:, None]
        lam = np.exp(xr[:, 3])
        a = lam[None, :, None] * axes[None] + blur * q[:, None, :]            # (Q, K, 3)
        dd = np.maximum(np.linalg.norm(a, axis=-1), 1e-12)
        # Wang09 eq 4 / S(λ_b): v = 2π e^{d − λ_k − λ_b}(1 − e^{−2d})/d / S(λ_b)
        v = 2.0 * np.pi * np.exp(dd - lam[None] - blur) * (-np.expm1(-2.0 * dd)) / dd / s_b
        return xr, nx, axes, lam, a, dd, v

    def residual(xx):
        xr, _, _, _, _, _, v = parts(xx)
        return ((v @ xr[:, 4:] - target) * sw).ravel()

    def jacobian(xx):
        """Analytic ∂r/∂(axis, ln λ, μ); g(d) = d ln(sinh d/d)/dd = coth d − 1/d."""
        xr, nx, axes, lam, a, dd, v = parts(xx)
        g = np.where(dd < 1e-3, dd / 3.0, 1.0 / np.tanh(np.maximum(dd, 1e-3)) - 1.0 / dd)
        ap = np.einsum("qkc,kc->qk", a, axes)
        dv_dl = lam[None] * v * (g * ap / dd - 1.0)                            # (Q, K)
        ta = a - ap[..., None] * axes[None]                                   # (I − ppᵀ) a
        dv_dx = (v * g * lam[None] / (dd * nx[None]))[..., None] * ta           # (Q, K, 3)
        mu = xr[:, 4:]
        J = np.zeros((len(q), 3, k, 7))
        J[:, :, :, 0:3] = np.einsum("qkx,kc->qckx", dv_dx, mu)
        J[:, :, :, 3] = np.einsum("qk,kc->qck", dv_dl, mu)
        for c in range(3):
            J[:, c, :, 4 + c] = v
        J *= sw[:, :, None, None]
        return J.reshape(len(q) * 3, k * 7)

    # lsmr: the dense 'exact' trust-region solve is ~20× slower here for the same iterations
    sol = least_squares(residual, x0, jac=jacobian, bounds=(lo, hi), method="trf",
                        tr_solver="lsmr", x_scale="jac", max_nfev=100 * k, ftol=1e-8, xtol=1e-8)
    axes, lam, mu = _unpack(sol.x, k)
    lam, mu = _sharpen_small_sources(axes, lam, mu, d, om, rad, 4.0 * blur, lambda_max)
    order = np.argsort(-(mu.sum(1) / lam))      # most power first
    return SGLight(axes[order], lam[order], mu[order])
