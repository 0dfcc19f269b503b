"""ASG mixtures of anisotropic microfacet NDFs (Xu et al. 2013, "Anisotropic Spherical
Gaussians", eq 4): D(h) ≈ Σ_l c_l max(h·n, 0) e^{−λ_l (h·t)² − μ_l (h·b)²} in the tangent frame,
from the slopes (the peak curvature, e.g. Beckmann λ = 1/α_u² − 5/2) or fitted by
Levenberg–Marquardt on the slope-space quadrature of the exact D."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from sgpipe.core.asg import asg_eval
from sgpipe.core.quadrature import lobe_quadrature
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


def _peak_curvature(ndf) -> tuple[float, float]:
    """κ_t, κ_b with ln D ≈ −κ_t (h·t)² − κ_b (h·b)² at the pole: Beckmann 1/α² − 2 (its
    1/cos⁴θ), Ward 1/α², GGX 2/α² − 2 ((1 + s²/α²)⁻² ≈ e^{−2s²/α²}), Ashikhmin–Shirley n/2."""
    name = getattr(ndf, "name", "")
    if name == "ashikhmin_shirley":
        return ndf.nu / 2.0, ndf.nv / 2.0
    au, av = ndf_alphas(ndf)
    scale, shift = {"beckmann": (1.0, -2.0), "ward": (1.0, 0.0), "ggx": (2.0, -2.0)}.get(
        name, (1.0, 0.0))
    return scale / au**2 + shift, scale / av**2 + shift


def analytic_ndf_asg(ndf) -> NdfASG:
    """The ASG with the NDF's peak value (1: sgpipe's NDFs peak at 1) and peak curvature along
    t and b (from the slopes, _peak_curvature), less the ½ that the ASG's own max(h·z, 0)
    factor contributes: λ = κ_t − ½, μ = κ_b − ½."""
    kt, kb = _peak_curvature(ndf)
    return NdfASG(_Z[None].copy(), _X[None].copy(), np.array([max(kt - 0.5, 0.1)]),
                  np.array([max(kb - 0.5, 0.1)]), np.array([1.0]), "analytic")


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
    lobe spread over sharpness in ×3 steps. `rel_l2` is the relative L2 error vs D there."""
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

    # one start: starts spread ×/÷ 2, 3 and 5 reached the same optimum on GGX 0.3/0.06
    k = 3.0 ** (np.arange(n_lobes) - (n_lobes - 1) / 2.0)
    p0 = np.column_stack([np.full(n_lobes, -np.log(n_lobes)),
                          np.log(an.sharpness_x[0] * k), np.log(an.sharpness_y[0] * k)])
    best = least_squares(res, p0.ravel(), jac=jac, method="lm", max_nfev=50 * (n_lobes + 1))
    p = best.x.reshape(-1, 3)
    p[:, 1:] = np.clip(p[:, 1:], *_LOG_BOUND)
    order = np.argsort(p[:, 1])
    p = p[order]
    fit = NdfASG(np.tile(_Z, (n_lobes, 1)), np.tile(_X, (n_lobes, 1)), np.exp(p[:, 1]),
                 np.exp(p[:, 2]), np.exp(p[:, 0]), "lm")
    fit.rel_l2 = hemisphere_rel_l2(ndf, fit)
    return fit


def hemisphere_rel_l2(ndf, fit) -> float:
    """Relative L2 error of a fit vs D over the whole hemisphere of h (polar panels graded
    about n for the sharper α, 720 azimuths): the slope-space rule of the fit stops at 20 α,
    where GGX still has tails."""
    a = min(ndf_alphas(ndf))
    h, w = lobe_quadrature((0.0, 0.0, 1.0), 1.0 / a**2, n_per_panel=48, n_phi=720,
                           hemisphere=True)
    return rel_l2(ndf.eval(h), fit.eval(h), w)


def ndf_asg(ndf, n_lobes: int = 0, *, tolerance: float = 0.02) -> tuple[NdfASG, dict]:
    """The ASG fit the fit stage writes and its report: n_lobes = 0 picks the fewest lobes
    (1–3) whose relative L2 error is ≤ `tolerance`, or stops where one lobe more gains < 25 %
    (GGX's heavy tails: 3, which the sun's reflection needs; Beckmann, Ward: 1); the analytic
    lobe's error is reported."""
    q = slope_quadrature(*ndf_alphas(ndf))
    an = analytic_ndf_asg(ndf)
    an.rel_l2 = hemisphere_rel_l2(ndf, an)
    curve, fit = [], None
    for n in ([n_lobes] if n_lobes else [1, 2, 3]):
        f = fit_ndf_asg(ndf, n, quadrature=q)
        curve.append(f.rel_l2)
        if fit is not None and f.rel_l2 > 0.75 * fit.rel_l2:
            break                      # a lobe more gains < 25 %: keep the fewer
        fit = f
        if fit.rel_l2 <= tolerance:
            break
    rep = {"lobes": len(fit.amplitude), "method": fit.method, "rel_l2": fit.rel_l2,
           "sharpness_x": fit.sharpness_x, "sharpness_y": fit.sharpness_y,
           "amplitude": fit.amplitude, "analytic_rel_l2": an.rel_l2,
           "rel_l2_by_lobes": curve}
    return fit, rep
