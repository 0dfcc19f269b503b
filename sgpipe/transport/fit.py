"""Green06 §4.2: fit N Gaussians per view to one vertex's transport over all 92 views at once,
minimising eq 6 (α D + β M + γ V + δ S) by Levenberg–Marquardt with analytic Jacobians
(`_lm_jit`): the normal equations are solved matrix-free by block-preconditioned conjugate
gradients, because the coherence terms couple every view to its neighbours.

Views below the vertex's horizon carry no data and a weight fixed at zero; their means and
σ are filled in smoothly by the coherence terms alone (the paper's horizon fill-in).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from sgpipe.transport import _lm_jit as K_
from sgpipe.transport.views import view_set


@dataclass(frozen=True)
class FitOptions:
    """Eq 6's weights and the solver's limits."""

    gaussians: int = 1
    alpha: float = 1.0          # data term D (each view's normalised by its ‖T_v‖²)
    beta: float = 0.05          # mean coherence M
    gamma: float = 0.05         # σ coherence V
    delta: float = 1.0          # spatial term S (only with ≥ 2 Gaussians)
    max_iter: int = 40
    ftol: float = 1e-3          # stop when an accepted step lowers F by less than this fraction
                                # (the per-view start phase uses ftol/10)
    sigma_min: float = 0.005    # radians
    sigma_max: float = 1.5
    cg_iter: int = 60
    independent_start: bool = True   # LM per view on its data alone before the joint solve


@dataclass
class VertexFit:
    """One vertex's Gaussians: mu (V, K, 3), sigma (V, K), w (V, K, 3); F the objective, rel_err
    the relative L2 error over all active views (`relative_error`), iters the LM steps."""

    mu: np.ndarray
    sigma: np.ndarray
    w: np.ndarray
    F: float
    rel_err: float
    iters: int


class VertexProblem:
    """The data of eq 6 for one vertex: transport T (V, M, 3) over light texels (dirs, omega),
    the active (above-horizon) views, and the processed neighbours' means for eq 10."""

    def __init__(self, T, active, dirs, omega, opts: FitOptions, normal, nb_means=None):
        self.T = np.ascontiguousarray(T, np.float64)
        self.active = np.ascontiguousarray(active, np.bool_)
        self.dirs = np.ascontiguousarray(dirs, np.float64)
        self.omega = np.ascontiguousarray(omega, np.float64)
        self.opts = opts
        self.normal = np.asarray(normal, float)
        self.views, _, self.nb, self.cnt = view_set()
        # per-view normalisation E_v (floored at 1 % of the mean, so views that receive almost
        # nothing still pull their weights towards zero without amplifying round-off); a vertex
        # whose transport float32 storage cannot hold has energy 0 and is fitted as none (its
        # energy would underflow and 1/E_v overflow)
        energy = np.einsum("vmc,m->v", self.T ** 2, self.omega)
        n_act = max(int(self.active.sum()), 1)
        self.energy = (0.0 if negligible_transport(self.T[self.active])
                       else float(energy[self.active].sum() / n_act))
        floor = 0.01 * self.energy if self.energy > 0 else 1.0
        self.av = opts.alpha / np.maximum(energy, floor)
        k = opts.gaussians
        self.nbmu = (np.zeros((0, len(self.views), k, 3)) if nb_means is None
                     else np.ascontiguousarray(nb_means, np.float64))
        self.free = np.ones((len(self.views), K_.P * k), np.bool_)
        for kk in range(k):
            self.free[~self.active, K_.P * kk + 3:K_.P * kk + 6] = False
        self.s_lo, self.s_hi = np.log(opts.sigma_min), np.log(opts.sigma_max)

    def evaluate(self, mu, s, w, jac: bool):
        """(F, data part, H blocks, g, tangent bases) at the parameters."""
        o = self.opts
        V, k = mu.shape[0], mu.shape[1]
        tb = K_.tangent_bases(mu)
        H = np.zeros((V, K_.P * k, K_.P * k))
        g = np.zeros((V, K_.P * k))
        Fd = K_.data_term(self.T, self.active, self.dirs, self.omega, self.av, mu, s, w, tb, H,
                          g, jac)
        Fc = K_.coherence_term(mu, s, self.nb, self.cnt, tb, o.beta, o.gamma, g, jac)
        Fs = K_.spatial_term(mu, tb, self.nbmu, o.delta, H, g, jac)
        return Fd + Fc + Fs, Fd, H, g, tb


def negligible_transport(T) -> bool:
    """True where no texel of T reaches float32's smallest normal number: nothing the compact
    artifact stores, and below the range where eq 6's per-view normalisation is finite."""
    return not (np.abs(T) >= np.finfo(np.float32).tiny).any()


def gaussian(dirs, mu, sigma):
    """G(ω; μ, σ) = exp((ω·μ − 1)/σ²) (Green06 eq 4 with peak 1)."""
    # ω·μ ≤ 1 for unit vectors; the clamp keeps a rounding excess (or a caller's non-unit μ)
    # from overflowing exp
    return np.exp(np.minimum(np.asarray(dirs) @ np.asarray(mu) - 1.0, 0.0)
                  / np.asarray(sigma) ** 2)


def solve_weights(T, dirs, omega, mu, sigma):
    """Non-negative least-squares RGB weights (K, 3) of fixed Gaussians (K, 3)/(K,) against
    T (M, 3) in the solid-angle metric (Lawson–Hanson NNLS per channel)."""
    sq = np.sqrt(omega)[:, None]
    G = np.stack([gaussian(dirs, m, sg) for m, sg in zip(mu, sigma)], axis=1) * sq  # (M, K)
    b = T * sq
    return np.stack([nnls(G, b[:, c])[0] for c in range(3)], axis=1)


def init_params(prob: VertexProblem):
    """Per active view: the first Gaussian from the luminance's mean direction and resultant
    length (Banerjee's κ, σ = 1/√κ), further ones at the largest residual texel; least-squares
    weights. Inactive views copy the nearest active view's means and σ with zero weight."""
    k, V = prob.opts.gaussians, len(prob.views)
    mu = np.zeros((V, k, 3))
    sig = np.full((V, k), 0.3)
    w = np.zeros((V, k, 3))
    refl = 2.0 * (prob.views @ prob.normal)[:, None] * prob.normal - prob.views
    for v in range(V):
        mu[v, :] = refl[v] / max(np.linalg.norm(refl[v]), 1e-300)
        if not prob.active[v]:
            continue
        lum = prob.T[v].mean(-1) * prob.omega
        peak = lum.max()
        if not peak > 0:
            continue
        # scaled to peak 1 first: a view lit only by a sharp lobe's far tail has texels near
        # 1e-170, whose mean vector's squared norm underflows to 0
        lum = lum / peak
        tot = lum.sum()
        m = lum @ prob.dirs
        norm_m = np.linalg.norm(m)
        if not norm_m > 0:
            continue
        r = min(norm_m / tot, 0.999)
        mu[v, 0] = m / norm_m
        kappa = max(r * (3 - r * r) / (1 - r * r), 1e-3)
        sig[v, :] = np.clip(1.0 / np.sqrt(kappa), prob.opts.sigma_min, prob.opts.sigma_max)
        for kk in range(1, k):
            w[v, :kk] = solve_weights(prob.T[v], prob.dirs, prob.omega, mu[v, :kk], sig[v, :kk])
            approx = sum(w[v, q] * gaussian(prob.dirs, mu[v, q], sig[v, q])[:, None]
                         for q in range(kk))
            mu[v, kk] = prob.dirs[np.argmax((prob.T[v] - approx).mean(-1))]
            sig[v, kk] = max(sig[v, 0] * 0.5, prob.opts.sigma_min)
        w[v] = solve_weights(prob.T[v], prob.dirs, prob.omega, mu[v], sig[v])
    _fill_inactive(prob, mu, sig)
    return mu, np.log(sig), w


def init_from_neighbour(prob: VertexProblem, nb_fit: VertexFit):
    """Flood-fill start: a fitted neighbour's means and σ, weights re-solved on this data."""
    mu = nb_fit.mu.copy()
    sig = np.clip(nb_fit.sigma.copy(), prob.opts.sigma_min, prob.opts.sigma_max)
    w = np.zeros_like(nb_fit.w)
    for v in np.flatnonzero(prob.active):
        w[v] = solve_weights(prob.T[v], prob.dirs, prob.omega, mu[v], sig[v])
    return mu, np.log(sig), w


def _fill_inactive(prob, mu, sig):
    act = np.flatnonzero(prob.active)
    if not len(act):
        return
    for v in np.flatnonzero(~prob.active):
        near = act[np.argmax(prob.views[act] @ prob.views[v])]
        mu[v], sig[v] = mu[near], sig[near]


def _held_weights(w, g):
    """(V, 6K) weights the bound w ≥ 0 holds this step: at zero with −g pointing below it."""
    V, k = w.shape[0], w.shape[1]
    held = np.zeros((V, K_.P * k), bool)
    for kk in range(k):
        held[:, K_.P * kk + 3:K_.P * kk + 6] = (w[:, kk] <= 0.0) & (g[:, K_.P * kk + 3:
                                                                        K_.P * kk + 6] >= 0.0)
    return held


def fit_vertex(prob: VertexProblem, start=None) -> VertexFit:
    """Levenberg–Marquardt on eq 6 from `start` (mu, s, w) or `init_params`: first every active
    view's data term alone (each with its own damping), then all views jointly with the
    coherence and spatial terms; weights projected onto w ≥ 0 throughout."""
    o = prob.opts
    mu, s, w = start if start is not None else init_params(prob)
    mu, s = mu.copy(), s.copy()
    if prob.energy == 0.0:
        # no glossy transport in any view (a diffuse material, a fully occluded vertex, or
        # only a sharp lobe's far tail): all weights are zero and nothing of this vertex is
        # stored or rendered
        return VertexFit(mu, np.exp(s), np.zeros_like(w), 0.0, 0.0, 0)
    w = np.where(prob.active[:, None, None], np.maximum(w, 0.0), 0.0)
    if o.independent_start:
        K_.fit_views_independently(prob.T, prob.active, prob.dirs, prob.omega, prob.av, mu, s,
                                   w, prob.s_lo, prob.s_hi, o.max_iter, 0.1 * o.ftol)
    F, Fd, H, g, tb = prob.evaluate(mu, s, w, True)
    lam, it = 1e-2, 0
    for it in range(1, o.max_iter + 1):
        sig = np.exp(s)
        selfd = K_.self_diagonal(prob.nb, prob.cnt, sig, o.beta, o.gamma, o.gaussians)
        D = np.einsum("vpp->vp", H) + selfd
        D = np.maximum(D, 1e-9 * max(float(D.max()), 1e-300))
        accepted = False
        free = prob.free & ~_held_weights(w, g)
        while lam < 1e10:
            x = K_.solve_step(H, g, prob.nb, prob.cnt, tb, sig, o.beta, o.gamma, lam, D, selfd,
                              free, o.cg_iter, 1e-6)
            mu2, s2, w2 = K_.retract(mu, s, w, tb, x, prob.s_lo, prob.s_hi)
            F2, Fd2, _, _, _ = prob.evaluate(mu2, s2, w2, False)
            if F2 < F:
                accepted = True
                break
            lam *= 4.0
        if not accepted:
            break
        done = F - F2 <= o.ftol * F
        mu, s, w = mu2, s2, w2
        lam = max(lam / 3.0, 1e-9)
        F, Fd, H, g, tb = prob.evaluate(mu, s, w, True)
        if done:
            break
    return VertexFit(mu, np.exp(s), w, float(F), relative_error(prob, mu, s, w), it)


def relative_error(prob: VertexProblem, mu, s, w) -> float:
    """The vertex's relative L2 error over all its active views and light texels,
    √(Σ_vj Ω_j ‖T̃_vj − T_vj‖² / Σ_vj Ω_j ‖T_vj‖²): pooled, so that views in shadow (whose
    transport is 10⁻⁶ of the vertex's) count by their energy, as they do in an image."""
    V = len(prob.views)
    tb = K_.tangent_bases(mu)
    num = K_.data_term(prob.T, prob.active, prob.dirs, prob.omega, np.ones(V), mu, s, w, tb,
                       np.zeros((V, 1, 1)), np.zeros((V, 1)), False)
    den = float(np.einsum("vmc,m->", prob.T[prob.active] ** 2, prob.omega))
    return float(np.sqrt(num / den)) if den > 0 else 0.0


__all__ = ["FitOptions", "VertexFit", "VertexProblem", "negligible_transport", "gaussian",
           "solve_weights", "init_params", "init_from_neighbour", "fit_vertex", "relative_error"]
