"""SG mixtures of microfacet NDFs (Wang09 §4.1–4.2): analytic lobes (eq 12 and equivalents),
Levenberg–Marquardt fits about +z for isotropic NDFs, L-BFGS-B fits with free axes, and the
lobe-count rule (`auto_ndf_sg`) that gives heavy-tailed NDFs (GGX) the lobes their tails need."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, minimize

from sgpipe.core.quadrature import gauss_legendre, lobe_quadrature
from sgpipe.fit._sg_fit_jit import sg_l2_objective
from sgpipe.fit.em import spherical_em

_LAM_MIN, _LAM_MAX = 1e-2, 1e6
#: `auto_ndf_sg` targets for isotropic NDFs: relative L2 error of D and relative error of the
#: projected area ∫ D cos θ dω (the energy in the tails, which L2 weighs little)
AUTO_REL_L2 = 0.01
AUTO_AREA_ERR = 0.02
AUTO_MAX_LOBES = 6
#: the third target, the tails: RMS relative error of D over the half-vectors where D is at
#: least TAIL_FLOOR of its peak (`tail_error`). A light 10⁴ × brighter than its surroundings
#: (a studio lamp) spreads D's tail down to 10⁻⁴ of the peak over the whole lobe as visible
#: glow, which L2 and the projected area do not see: GGX's power-law tail (D ∝ 1/θ⁴) beyond
#: the first lobes' reach is energy well under AUTO_AREA_ERR but the whole signal there.
TAIL_FLOOR = 1e-4
AUTO_TAIL_ERR = 0.1
AUTO_MAX_TAIL_LOBES = 8
#: weight of the relative residuals (f − D)/(D + TAIL_FLOOR·max D) beside the L2 residuals in
#: the tail-aware LM fit (`fit_iso_lm`'s `tail`): enough to carry the fit into the tail, little
#: enough that the core still meets AUTO_REL_L2
TAIL_WEIGHT = 0.3
#: stop adding lobes when one more lowers the L2 error by less than this fraction: positive SG
#: mixtures are log-convex in 1 − cos θ, so they cannot follow a lighter-tailed D (Beckmann)
_AUTO_MIN_GAIN = 0.05


@dataclass
class NdfSG:
    """D(h) ≈ Σ_l amplitude_l e^{sharpness_l (h·axis_l − 1)} (docs/ARTIFACTS.md ndf_sg.npz)."""

    axis: np.ndarray        # (L,3)
    sharpness: np.ndarray   # (L,)
    amplitude: np.ndarray   # (L,)
    method: str
    rel_l2: float = float("nan")
    area_err: float = float("nan")   # relative error of ∫ D cos θ dω (fit_ndf_sg sets it)
    tail_err: float = float("nan")   # `tail_error` (fit_ndf_sg sets it)
    #: the fit's tail above D's on (solid-angle) average (fit_ndf_sg sets it)
    tail_heavy: bool = False

    def eval(self, h):
        h = np.asarray(h, float)
        return np.exp(self.sharpness * (h @ self.axis.T - 1.0)) @ self.amplitude

    def arrays(self) -> dict:
        f = np.float32
        return {"axis": self.axis.astype(f), "sharpness": self.sharpness.astype(f),
                "amplitude": self.amplitude.astype(f), "rel_l2": np.float32(self.rel_l2),
                "method": np.array(self.method)}


def iso_quadrature(width: float, n_per_panel: int = 24):
    """(cos θ (N,), weights (N,)) over the hemisphere of h, graded towards θ = 0 for a lobe of
    angular width `width` (weights include the 2π of the azimuth)."""
    dirs, w = lobe_quadrature((0.0, 0.0, 1.0), 1.0 / max(width, 1e-4) ** 2,
                              n_per_panel=n_per_panel, n_phi=1, hemisphere=True)
    return dirs[:, 2], w


def _slope_axis(alpha: float, step: float, extent: float, n_tail: int = 24, n_max: int = 400):
    """1-D rule on [−extent·α, extent·α]: Gauss–Legendre with spacing ≈ step on |x| ≤ 3α,
    log-graded Gauss–Legendre tails beyond."""
    core = 3.0 * alpha
    n_c = int(np.clip(np.ceil(1.2 * 2.0 * core / step), 16, n_max))
    xc, wc = gauss_legendre(n_c, -core, core)
    s, ws = gauss_legendre(n_tail, 0.0, np.log(max(extent / 3.0, 1.0 + 1e-9)))
    xt, wt = core * np.exp(s), core * np.exp(s) * ws
    return np.concatenate([-xt[::-1], xc, xt]), np.concatenate([wt[::-1], wc, wt])


def slope_quadrature(alpha_u: float, alpha_v: float, extent: float = 20.0, resolution: float = 4.0):
    """(h (N,3), weights (N,)) over the upper hemisphere in slope space (x, y) = (h_x, h_y)/h_z,
    |x| <= extent·α_u, |y| <= extent·α_v, node spacing min(α_u, α_v)/resolution in the core:
    resolves anisotropic NDF lobes and the round SG lobes that approximate them."""
    step = min(alpha_u, alpha_v) / resolution
    x, dx = _slope_axis(alpha_u, step, extent)
    y, dy = _slope_axis(alpha_v, step, extent)
    xx, yy = np.meshgrid(x, y, indexing="ij")
    q = 1.0 + xx**2 + yy**2
    h = np.stack([xx, yy, np.ones_like(xx)], -1) / np.sqrt(q)[..., None]
    w = np.outer(dx, dy) / q**1.5
    return h.reshape(-1, 3), w.ravel()


def rel_l2(values, approx, weights) -> float:
    den = float(np.sum(weights * values**2))
    return float(np.sqrt(np.sum(weights * (values - approx) ** 2) / den)) if den > 0 else 0.0


def analytic_ndf_sg(ndf) -> NdfSG | None:
    """Wang09 eq 12 (Cook–Torrance λ = 2/m², μ = 1) and the peak-curvature equivalents:
    Blinn–Phong λ = e, Ward λ = 2/α², Beckmann λ = 2/α² − 4, GGX λ = 4(1/α² − 1), A–S λ = n."""
    lm = ndf.sg_analytic()
    if lm is None:
        return None
    return NdfSG(np.array([[0.0, 0.0, 1.0]]), np.array([lm[0]]), np.array([lm[1]]), "analytic")


def _iso_model(p, c):
    lam = np.exp(p[0::2])
    mu = np.exp(p[1::2])
    e = np.exp(lam[None, :] * (c[:, None] - 1.0))
    return e, lam, mu


def iso_residuals(cos_t, values, weights):
    """(residual, Jacobian) of the isotropic model's weighted least squares in p = (ln λ, ln μ)
    per lobe, for scipy's `least_squares`."""
    sw = np.sqrt(weights)

    def res(p):
        # a trial step can overflow e^p for very sharp NDFs: its residual is then not finite
        # and the solver rejects the step, so the overflow is not worth a warning
        with np.errstate(over="ignore", invalid="ignore"):
            e, _, mu = _iso_model(p, cos_t)
            return sw * (e @ mu - values)

    def jac(p):
        e, lam, mu = _iso_model(p, cos_t)
        j = np.empty((cos_t.size, p.size))
        j[:, 0::2] = sw[:, None] * e * mu * lam * (cos_t[:, None] - 1.0)
        j[:, 1::2] = sw[:, None] * e * mu
        return j
    return res, jac


def _tail_residuals(cos_t, values, weights, tail: float):
    """iso_residuals of the L2 error normalised by ∫ D², stacked on `tail` × the relative error
    (f − D)/(D + TAIL_FLOOR·max D) normalised by the solid angle: one least-squares problem
    that weighs the core by L2 and the tail by its relative error."""
    floor = TAIL_FLOOR * float(np.max(values))
    r1, j1 = iso_residuals(cos_t, values, weights / float(np.sum(weights * values**2)))
    r2, j2 = iso_residuals(cos_t, values, tail**2 * weights / (values + floor) ** 2
                           / float(np.sum(weights)))
    return (lambda p: np.concatenate([r1(p), r2(p)])), (lambda p: np.vstack([j1(p), j2(p)]))


def fit_iso_lm(cos_t, values, weights, n_lobes: int, lam0: float,
               tail: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Levenberg–Marquardt (scipy `least_squares(method='lm')`) fit of n SG lobes about +z to an
    isotropic function D(cos θ); several starts spread around λ0. `tail` > 0 adds the tail's
    relative error to the L2 objective (`_tail_residuals`). Returns (λ, μ) by sharpness."""
    res, jac = (_tail_residuals(cos_t, values, weights, tail) if tail > 0
                else iso_residuals(cos_t, values, weights))

    best = None
    for spread in (2.0, 4.0, 8.0):
        k = np.arange(n_lobes) - (n_lobes - 1) / 2.0
        lam = np.clip(lam0 * spread ** k, _LAM_MIN, _LAM_MAX)
        p0 = np.ravel(np.column_stack([np.log(lam), np.log(np.full(n_lobes, 1.0 / n_lobes))]))
        try:
            r = least_squares(res, p0, jac=jac, method="lm", max_nfev=400 * (n_lobes + 1))
        except ValueError:   # more parameters than residuals
            continue
        if best is None or r.cost < best.cost:
            best = r
    p = best.x
    lam = np.clip(np.exp(p[0::2]), _LAM_MIN, _LAM_MAX)
    mu = np.exp(p[1::2])
    order = np.argsort(lam)
    return lam[order], mu[order]


def _single_thread_blas():
    """L-BFGS-B does tiny BLAS calls; a threaded OpenBLAS makes them ~5x slower on a busy
    machine. threadpoolctl is optional (present with the dev extras)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover
        from contextlib import nullcontext
        return nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def _unpack(p, n):
    p = p.reshape(n, 5)
    v = p[:, :3]
    nv = np.linalg.norm(v, axis=1, keepdims=True)
    return v / nv, nv, np.exp(p[:, 3]), np.exp(p[:, 4])


def fit_free_lbfgsb(h, weights, values, init: NdfSG, max_iter: int = 600) -> NdfSG:
    """L-BFGS-B (scipy) fit of SG lobes with free axes, sharpness and amplitude to values at
    quadrature points h (N,3) — minimises Σ w (Σ_l G_l(h) − D(h))² with an analytic gradient."""
    n = init.axis.shape[0]
    scale = float(np.sum(weights * values**2))

    ga = np.empty((n, 3))
    gl = np.empty(n)
    gm = np.empty(n)
    h = np.ascontiguousarray(h, dtype=float)
    weights = np.ascontiguousarray(weights, dtype=float)
    values = np.ascontiguousarray(values, dtype=float)

    def fg(p):
        ax, nv, lam, mu = _unpack(p, n)
        f = sg_l2_objective(h, weights, values, np.ascontiguousarray(ax), lam, mu, ga, gl, gm)
        g = np.empty((n, 5))
        g[:, :3] = (ga - np.sum(ga * ax, 1, keepdims=True) * ax) / nv   # through p = v/‖v‖
        g[:, 3] = gl
        g[:, 4] = gm
        return f / scale, g.ravel() / scale

    p0 = np.column_stack([init.axis, np.log(np.clip(init.sharpness, _LAM_MIN, _LAM_MAX)),
                          np.log(np.maximum(init.amplitude, 1e-12))]).ravel()
    bounds = [(None, None)] * 3 + [(np.log(_LAM_MIN), np.log(_LAM_MAX)), (-30.0, 5.0)]
    with _single_thread_blas():
        r = minimize(fg, p0, jac=True, method="L-BFGS-B", bounds=bounds * n,
                     options={"maxiter": max_iter, "ftol": 1e-10, "gtol": 1e-9})
    ax, _, lam, mu = _unpack(r.x, n)
    return NdfSG(ax, lam, mu, "lbfgsb")


def em_init(ndf, n_lobes: int, n_samples: int = 4096, seed: int = 0) -> NdfSG:
    """Initial free-axis lobes from spherical EM on importance samples of D (weights D/pdf_h)."""
    rng = np.random.default_rng(seed)
    u = rng.random((2, n_samples))
    h = ndf.sample_h(u[0], u[1])
    pdf = ndf.pdf_h(h)
    ok = pdf > 0
    w = np.where(ok, ndf.eval(h) / np.where(ok, pdf, 1.0), 0.0)
    mix = spherical_em(h, w, n_lobes, max_iter=200)
    total = float(np.mean(w))
    kappa = np.maximum(mix.kappa, 1e-3)
    amp = mix.alpha * total * kappa / (2.0 * np.pi * -np.expm1(-2.0 * kappa))
    return NdfSG(mix.mu, kappa, amp, "em")


def _ndf_alphas(ndf):
    """Slope-space scales (α_u, α_v) of an anisotropic NDF (A–S: α ≈ √(2/(n+2)))."""
    if hasattr(ndf, "au"):
        return ndf.au, ndf.av
    if hasattr(ndf, "nu"):
        return np.sqrt(2.0 / (ndf.nu + 2.0)), np.sqrt(2.0 / (ndf.nv + 2.0))
    return ndf.width(), ndf.width()


def fit_ndf_sg(ndf, *, method: str = "auto", n_lobes: int = 1, seed: int = 0,
               init: NdfSG | None = None, tail: float = 0.0) -> NdfSG:
    """Wang09 §4: analytic for isotropic parametric NDFs, LM about +z for isotropic NDFs
    (tabulated; 1–2 lobes), L-BFGS-B with free axes for anisotropic NDFs; n_lobes = 0: the
    count of `auto_ndf_sg`. The relative L2 error vs the exact D over the hemisphere of h is
    stored in `rel_l2`, the relative error of its projected area in `area_err`, the tail's
    relative error in `tail_err`. `tail` > 0: the LM fit weighs the tail too (TAIL_WEIGHT)."""
    if n_lobes == 0:
        return auto_ndf_sg(ndf, method=method, seed=seed)
    iso = ndf.isotropic
    if method == "auto":
        method = ("analytic" if ndf.sg_analytic() is not None and n_lobes == 1 else "lm") \
            if iso else "lbfgsb"
    if method in ("analytic", "lm") and not iso:
        raise ValueError(f"method {method!r} needs an isotropic NDF")
    if iso:
        c, w = iso_quadrature(ndf.width())
        h = np.stack([np.sqrt(np.maximum(0.0, 1 - c * c)), np.zeros_like(c), c], -1)
        d = ndf.eval(h)
    else:
        h, w = slope_quadrature(*_ndf_alphas(ndf))
        d = ndf.eval(h)
    if method == "analytic":
        sg = analytic_ndf_sg(ndf)
        if sg is None:
            raise ValueError(f"no analytic SG for NDF {ndf.name!r}")
    elif method == "lm":
        lam0 = ndf.sg_analytic()[0] if ndf.sg_analytic() else 2.0 / ndf.width() ** 2
        lam, mu = fit_iso_lm(c, d, w, n_lobes, lam0, tail)
        sg = NdfSG(np.tile([0.0, 0.0, 1.0], (n_lobes, 1)), lam, mu, "lm")
    elif method == "lbfgsb":
        sg = fit_free_lbfgsb(h, w, d, init if init is not None else em_init(ndf, n_lobes,
                                                                           seed=seed))
    else:
        raise ValueError(f"unknown NDF fit method {method!r}")
    sg.rel_l2 = rel_l2(d, sg.eval(h), w)
    sg.area_err = projected_area_error(d, sg.eval(h), w, h[:, 2])
    sg.tail_err = tail_error(d, sg.eval(h), w)
    rel, wt = _tail_relative(d, sg.eval(h), w)
    sg.tail_heavy = float(np.sum(wt * rel)) > 0.0
    return sg


def projected_area_error(values, approx, weights, cos_t) -> float:
    """Relative error of ∫ D(h) (h·n) dω_h (= 1 for a normalised D): the energy of the lobe."""
    den = float(np.sum(weights * values * cos_t))
    return float(np.sum(weights * approx * cos_t)) / den - 1.0 if den > 0 else 0.0


def _tail_relative(values, approx, weights):
    """(f/D − 1, solid-angle weights) where D ≥ TAIL_FLOOR · max D."""
    keep = values >= TAIL_FLOOR * float(np.max(values))
    return approx[keep] / values[keep] - 1.0, weights[keep]


def tail_error(values, approx, weights) -> float:
    """RMS relative error |f/D − 1| over the directions where D ≥ TAIL_FLOOR · max D, weighted by
    solid angle: how far the fit's glow around a bright light is from D's."""
    rel, w = _tail_relative(values, approx, weights)
    return float(np.sqrt(np.sum(w * rel * rel) / np.sum(w))) if np.sum(w) > 0 else 0.0


def _meets_targets(sg: NdfSG, tails: bool = False) -> bool:
    return (sg.rel_l2 <= AUTO_REL_L2 and abs(sg.area_err) <= AUTO_AREA_ERR
            and (not tails or sg.tail_err <= AUTO_TAIL_ERR))


def auto_ndf_sg(ndf, *, method: str = "auto", seed: int = 0) -> NdfSG:
    """`fit.ndf_sg.lobes: 0`. Isotropic NDFs: Wang09's analytic lobe (eq 12) when it meets the
    targets (AUTO_REL_L2 on D, AUTO_AREA_ERR on ∫ D cos θ, AUTO_TAIL_ERR on the tail), else the
    fewest LM lobes about +z that meet the first two, adding lobes up to AUTO_MAX_LOBES while
    each still helps, and where those miss the tail target, `_tail_fit` (sharp GGX: 5 lobes).
    `method` analytic: the one analytic lobe; lbfgsb: 2 lobes (isotropic) or 8 with free axes
    (anisotropic, also auto's choice there)."""
    if method not in ("auto", "analytic", "lm", "lbfgsb"):
        raise ValueError(f"unknown NDF fit method {method!r}")
    if method == "analytic":
        return fit_ndf_sg(ndf, method="analytic")
    if method == "lbfgsb" or not ndf.isotropic:
        return fit_ndf_sg(ndf, method=method, n_lobes=2 if ndf.isotropic else 8, seed=seed)
    if method == "auto" and ndf.sg_analytic() is not None:
        sg = fit_ndf_sg(ndf, method="analytic")
        if _meets_targets(sg, tails=True):
            return sg
    best = fit_ndf_sg(ndf, method="lm", n_lobes=1, seed=seed)
    for n in range(2, AUTO_MAX_LOBES + 1):
        if _meets_targets(best):
            break
        nxt = fit_ndf_sg(ndf, method="lm", n_lobes=n, seed=seed)
        if nxt.rel_l2 > (1.0 - _AUTO_MIN_GAIN) * best.rel_l2:
            break
        best = nxt
    return best if _meets_targets(best, tails=True) else _tail_fit(ndf, best, seed)


def _tail_fit(ndf, best: NdfSG, seed: int) -> NdfSG:
    """The tail-aware LM fit (TAIL_WEIGHT) with the fewest lobes, from best's count up to
    AUTO_MAX_TAIL_LOBES, that meets all three targets; else the one with the smallest tail
    error that meets the other two, where it at least halves best's; else best (a positive SG
    mixture is log-convex in 1 − cos θ and cannot follow a lighter tail than its widest lobe:
    Beckmann's, Ward's: `tail_heavy`, the fit's tail above D's on average)."""
    if best.tail_heavy:
        return best
    cand = None
    for n in range(max(2, best.axis.shape[0]), AUTO_MAX_TAIL_LOBES + 1):
        sg = fit_ndf_sg(ndf, method="lm", n_lobes=n, seed=seed, tail=TAIL_WEIGHT)
        if _meets_targets(sg, tails=True):
            return sg
        if _meets_targets(sg) and (cand is None or sg.tail_err < cand.tail_err):
            cand = sg
    return cand if cand is not None and cand.tail_err < 0.5 * best.tail_err else best


def _add_lobe(sg: NdfSG, h, w, d) -> NdfSG:
    """Grow a fit by one lobe at the largest weighted positive residual (warm start)."""
    r = (d - sg.eval(h)) * np.sqrt(w)
    k = int(np.argmax(r))
    lam = float(np.max(sg.sharpness))
    amp = max(float(d[k] - sg.eval(h[k:k + 1])[0]), 1e-3 * float(d.max()))
    return NdfSG(np.vstack([sg.axis, h[k]]), np.append(sg.sharpness, lam),
                 np.append(sg.amplitude, amp), sg.method)


def ndf_error_curve(ndf, max_lobes: int, *, seed: int = 0) -> list[NdfSG]:
    """Best fits for 1…N lobes: LM about +z if isotropic, else L-BFGS-B grown greedily (each fit
    warm-starts from the previous one plus a lobe at the largest residual, so errors never rise)."""
    if ndf.isotropic:
        return [fit_ndf_sg(ndf, method="lm", n_lobes=n, seed=seed)
                for n in range(1, max_lobes + 1)]
    h, w = slope_quadrature(*_ndf_alphas(ndf))
    d = ndf.eval(h)
    fits = [fit_ndf_sg(ndf, method="lbfgsb", n_lobes=1, seed=seed)]
    for n in range(2, max_lobes + 1):
        fits.append(fit_ndf_sg(ndf, method="lbfgsb", n_lobes=n, seed=seed,
                               init=_add_lobe(fits[-1], h, w, d)))
    return fits
