"""ASG mixtures of anisotropic microfacet NDFs (Xu et al. 2013, "Anisotropic Spherical
Gaussians", eq 4): D(h) ≈ Σ_l c_l max(h·n, 0) e^{−λ_l (h·t)² − μ_l (h·b)²} in the tangent frame,
from the slopes (λ = 1/α_u², μ = 1/α_v²) or fitted by Levenberg–Marquardt on the slope-space
quadrature of the exact D."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from sgpipe.core.asg import asg_eval
from sgpipe.fit.ndf_sg import rel_l2, slope_quadrature

_Z = np.array([0.0, 0.0, 1.0])
_X = np.array([1.0, 0.0, 0.0])
_LOG_BOUND = (np.log(1e-2), np.log(1e7))


@dataclass
class NdfASG:
    """D(h) ≈ Σ_l amplitude_l max(h·z_l, 0) e^{−λ_l (h·x_l)² − μ_l (h·y_l)²}, y = z × x
    (docs/ARTIFACTS.md ndf_asg.npz)."""

    z: np.ndarray           # (L,3) lobe axes
    x: np.ndarray           # (L,3) axes of sharpness λ (⊥ z)
    sharpness_x: np.ndarray  # (L,) λ
    sharpness_y: np.ndarray  # (L,) μ
    amplitude: np.ndarray   # (L,) c
    method: str
    rel_l2: float = float("nan")

    def eval(self, h):
        h = np.asarray(h, float)
        out = np.zeros(h.shape[:-1])
        for z, x, lam, mu, c in zip(self.z, self.x, self.sharpness_x, self.sharpness_y,
                                    self.amplitude):
            out += asg_eval(h, z, x, lam, mu, c)
        return out

    def arrays(self) -> dict:
        f = np.float32
        return {"z": self.z.astype(f), "x": self.x.astype(f),
                "sharpness_x": self.sharpness_x.astype(f),
                "sharpness_y": self.sharpness_y.astype(f), "amplitude": self.amplitude.astype(f),
                "rel_l2": np.float32(self.rel_l2), "method": np.array(self.method)}


def ndf_alphas(ndf) -> tuple[float, float]:
    """Slope-space scales (α_u, α_v) of an NDF (Ashikhmin–Shirley: α ≈ √(2/(n + 2)))."""
    if hasattr(ndf, "au"):
        return float(ndf.au), float(ndf.av)
    if hasattr(ndf, "nu"):
        return float(np.sqrt(2.0 / (ndf.nu + 2.0))), float(np.sqrt(2.0 / (ndf.nv + 2.0)))
    w = float(ndf.width())
    return w, w


def analytic_ndf_asg(ndf) -> NdfASG:
    """From the slopes: near the pole the slope along t is h·t, so e^{−(x/α_u)² − (y/α_v)²}
    (Beckmann, Ward, and GGX's and A–S's peak curvature) gives λ = 1/α_u², μ = 1/α_v², c = 1
    (sgpipe's NDFs peak at 1)."""
    au, av = ndf_alphas(ndf)
    return NdfASG(_Z[None].copy(), _X[None].copy(), np.array([1.0 / au**2]),
                  np.array([1.0 / av**2]), np.array([1.0]), "analytic")


def _model(p, h):
    """Σ_l e^{p_c} S e^{−e^{p_λ} hx² − e^{p_μ} hy²} and the terms (N, L)."""
    p = p.reshape(-1, 3)
    c, lam, mu = np.exp(p[:, 0]), np.exp(p[:, 1]), np.exp(p[:, 2])
    s = np.maximum(h[:, 2], 0.0)[:, None]
    e = s * np.exp(-lam[None] * h[:, :1] ** 2 - mu[None] * h[:, 1:2] ** 2)
    return e * c[None], (c, lam, mu, e)


def fit_ndf_asg(ndf, n_lobes: int = 1, *, quadrature=None) -> NdfASG:
    """Levenberg–Marquardt fit of n ASGs sharing the tangent frame (the NDF's symmetry axes) to
    D on the slope-space quadrature (minimises Σ w (Σ_l G_l − D)²); starts from the analytic
    lobe spread over sharpness ×/÷ 3 steps. `rel_l2` is the relative L2 error vs D there."""
    h, w = quadrature if quadrature is not None else slope_quadrature(*ndf_alphas(ndf))
    d = ndf.eval(h)
    sw = np.sqrt(w)
    an = analytic_ndf_asg(ndf)

    def res(p):
        return sw * (_model(p, h)[0].sum(1) - d)

    def jac(p):
        terms, (c, lam, mu, e) = _model(p, h)
        j = np.empty((len(h), p.size))
        j[:, 0::3] = sw[:, None] * terms
        j[:, 1::3] = -sw[:, None] * terms * lam[None] * h[:, :1] ** 2
        j[:, 2::3] = -sw[:, None] * terms * mu[None] * h[:, 1:2] ** 2
        return j

    best = None
    for spread in (2.0, 3.0, 5.0):
        k = spread ** (np.arange(n_lobes) - (n_lobes - 1) / 2.0)
        p0 = np.column_stack([np.full(n_lobes, -np.log(n_lobes)),
                              np.log(an.sharpness_x[0] * k), np.log(an.sharpness_y[0] * k)])
        r = least_squares(res, p0.ravel(), jac=jac, method="trf", max_nfev=200 * (n_lobes + 1),
                          bounds=([-30.0, _LOG_BOUND[0], _LOG_BOUND[0]] * n_lobes,
                                  [5.0, _LOG_BOUND[1], _LOG_BOUND[1]] * n_lobes))
        if best is None or r.cost < best.cost:
            best = r
        if n_lobes == 1:
            break
    p = best.x.reshape(-1, 3)
    order = np.argsort(p[:, 1])
    p = p[order]
    fit = NdfASG(np.tile(_Z, (n_lobes, 1)), np.tile(_X, (n_lobes, 1)), np.exp(p[:, 1]),
                 np.exp(p[:, 2]), np.exp(p[:, 0]), "lm")
    fit.rel_l2 = rel_l2(d, fit.eval(h), w)
    return fit


def ndf_asg(ndf, n_lobes: int = 0, *, tolerance: float = 0.05) -> tuple[NdfASG, dict]:
    """The ASG fit the fit stage writes and its report: n_lobes = 0 picks the fewest lobes
    (1–3) whose relative L2 error is ≤ `tolerance`; the analytic lobe's error is reported."""
    q = slope_quadrature(*ndf_alphas(ndf))
    d = ndf.eval(q[0])
    an = analytic_ndf_asg(ndf)
    an.rel_l2 = rel_l2(d, an.eval(q[0]), q[1])
    curve = []
    for n in ([n_lobes] if n_lobes else [1, 2, 3]):
        fit = fit_ndf_asg(ndf, n, quadrature=q)
        curve.append(fit.rel_l2)
        if fit.rel_l2 <= tolerance:
            break
    rep = {"lobes": len(fit.amplitude), "method": fit.method, "rel_l2": fit.rel_l2,
           "sharpness_x": fit.sharpness_x, "sharpness_y": fit.sharpness_y,
           "amplitude": fit.amplitude, "analytic_rel_l2": an.rel_l2,
           "rel_l2_by_lobes": curve}
    return fit, rep
