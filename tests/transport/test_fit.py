"""The eq 6 objective's analytic gradient vs finite differences, exact recovery of known
Gaussians from synthetic transport, and the coherence terms smoothing the view field."""

import numpy as np
import pytest

from sgpipe.transport import _lm_jit as K_
from sgpipe.transport.fit import (FitOptions, VertexFit, VertexProblem, fit_vertex, gaussian,
                                  init_from_neighbour, init_params, solve_weights)
from sgpipe.transport.sampling import light_cube
from sgpipe.transport.views import view_set

VIEWS, _, NB, CNT = view_set()
N = np.array([0.2, 0.9, 0.1]) / np.linalg.norm([0.2, 0.9, 0.1])
ACTIVE = VIEWS @ N > 0


def synthetic(cube, mu, sig, w):
    """T_v = Σ_k w_k G(·; μ_vk, σ_vk) on the active views, zero below the horizon."""
    T = np.zeros((92, len(cube.dirs), 3))
    for v in np.flatnonzero(ACTIVE):
        for k in range(mu.shape[1]):
            T[v] += gaussian(cube.dirs, mu[v, k], sig[v, k])[:, None] * w[v, k]
    return T


def reflected():
    m = 2 * (VIEWS @ N)[:, None] * N - VIEWS
    return m / np.linalg.norm(m, axis=1, keepdims=True)


def test_gradient_matches_finite_differences():
    rng = np.random.default_rng(1)
    cube = light_cube(8)
    K = 2
    mu = rng.normal(size=(92, K, 3))
    mu /= np.linalg.norm(mu, axis=-1, keepdims=True)
    T = np.abs(rng.normal(size=(92, len(cube.dirs), 3))) * ACTIVE[:, None, None]
    nbmu = rng.normal(size=(2, 92, K, 3))
    nbmu /= np.linalg.norm(nbmu, axis=-1, keepdims=True)
    opts = FitOptions(gaussians=K, alpha=1.3, beta=0.7, gamma=0.4, delta=2.0)
    prob = VertexProblem(T, ACTIVE, cube.dirs, cube.omega, opts, N, nb_means=nbmu)
    s = np.log(rng.uniform(0.2, 0.8, size=(92, K)))
    w = rng.uniform(0.1, 1.0, size=(92, K, 3)) * ACTIVE[:, None, None]
    F, _, H, g, tb = prob.evaluate(mu, s, w, True)
    _, _, _, _, _ = prob.evaluate(mu, s, w, False)
    # the spatial term must be active somewhere for this test to cover it
    assert K_.spatial_term(mu, tb, prob.nbmu, 2.0, np.zeros_like(H), np.zeros_like(g), False) > 0
    h = 1e-6
    for v in (0, 5, 17, 40, 77):
        for p in range(6 * K):
            x = np.zeros((92, 6 * K))
            x[v, p] = h
            Fp = prob.evaluate(*K_.retract(mu, s, w, tb, x, -50, 50), False)[0]
            Fm = prob.evaluate(*K_.retract(mu, s, w, tb, -x, -50, 50), False)[0]
            fd = (Fp - Fm) / (2 * h)
            if not prob.free[v, p]:
                continue
            assert fd == pytest.approx(2 * g[v, p], rel=1e-5, abs=1e-7), (v, p)
    # H is JᵀJ: symmetric, positive semi-definite blocks; apply_h agrees with them where the
    # coherence terms are off
    assert np.allclose(H, np.swapaxes(H, 1, 2))
    assert np.linalg.eigvalsh(H).min() > -1e-9 * np.abs(H).max()


def test_gauss_newton_matrix_is_jtj():
    """At an exact fit the residuals vanish, so the Hessian of F is exactly 2 JᵀJ: compare the
    matrix-free product (data + coherence) against finite differences of the gradient."""
    cube = light_cube(8)
    mu = reflected()[:, None, :]
    sig = np.full((92, 1), 0.3)
    w = np.tile([1.0, 0.6, 0.3], (92, 1, 1)) * ACTIVE[:, None, None]
    T = synthetic(cube, mu, sig, w)
    # a constant mean field zeroes the mean coherence residuals as well
    mu_c = np.tile(mu[0], (92, 1, 1))
    T = synthetic(cube, mu_c, sig, w)
    opts = FitOptions(beta=0.3, gamma=0.2)
    prob = VertexProblem(T, ACTIVE, cube.dirs, cube.omega, opts, N)
    s = np.log(sig)
    F, _, H, g, tb = prob.evaluate(mu_c, s, w, True)
    assert F < 1e-25
    rng = np.random.default_rng(0)
    x = rng.normal(size=(92, 6)) * prob.free
    out = np.empty_like(x)
    K_.apply_h(x, H, NB, CNT, tb, np.exp(s), 0.3, 0.2, 0.0, np.zeros_like(x), prob.free, out)
    h = 1e-6
    gp = prob.evaluate(*K_.retract(mu_c, s, w, tb, h * x, -50, 50), True)[3]
    gm = prob.evaluate(*K_.retract(mu_c, s, w, tb, -h * x, -50, 50), True)[3]
    # the gradient is taken in the tangent bases of the moved point; at an exact fit the
    # residual is zero, so the basis change enters only at second order
    fd = (gp - gm) / (2 * h) * prob.free
    assert np.allclose(out, fd, rtol=1e-4, atol=1e-6 * np.abs(out).max())


def test_fit_recovers_known_gaussians_exactly():
    cube = light_cube(16)
    mu = reflected()[:, None, :]
    sig = (0.15 + 0.1 * (VIEWS @ N) ** 2)[:, None]
    w = np.tile([1.0, 0.5, 0.2], (92, 1, 1))
    T = synthetic(cube, mu, sig, w)
    fit = fit_vertex(VertexProblem(T, ACTIVE, cube.dirs, cube.omega,
                                   FitOptions(beta=0.0, gamma=0.0), N))
    a = ACTIVE
    assert fit.rel_err < 1e-9
    assert np.degrees(np.arccos(np.clip(np.sum(fit.mu[a, 0] * mu[a, 0], -1), -1, 1))).max() < 1e-4
    assert np.abs(fit.sigma[a] - sig[a]).max() < 1e-9
    assert np.abs(fit.w[a] - w[a]).max() < 1e-9
    assert not fit.w[~a].any()


def test_two_gaussians_recovered_with_the_spatial_term_on():
    cube = light_cube(16)
    rng = np.random.default_rng(3)
    base = np.array([0.3, 0.8, -0.2])
    m1 = base / np.linalg.norm(base)
    m2 = np.array([-0.6, 0.6, 0.3]) / np.linalg.norm([-0.6, 0.6, 0.3])
    mu = np.tile(np.stack([m1, m2]), (92, 1, 1))
    sig = np.tile([0.12, 0.3], (92, 1))
    w = np.tile([[1.0, 0.8, 0.6], [0.3, 0.3, 0.4]], (92, 1, 1))
    T = synthetic(cube, mu, sig, w)
    a = ACTIVE
    # alone (no processed neighbour): found from the data-driven start, in either order
    alone = fit_vertex(VertexProblem(T, ACTIVE, cube.dirs, cube.omega, FitOptions(gaussians=2), N))
    assert alone.rel_err < 1e-6
    # flood fill: started from a processed neighbour whose lobes are ordered (narrow, broad)
    # and slightly different, with that neighbour in the spatial term
    nbmu = mu[None] + 0.02 * rng.normal(size=(1, 92, 2, 3))
    nbmu /= np.linalg.norm(nbmu, axis=-1, keepdims=True)
    nb = VertexFit(nbmu[0], sig * 1.1, w * 0.9, 0.0, 0.0, 0)
    prob = VertexProblem(T, ACTIVE, cube.dirs, cube.omega, FitOptions(gaussians=2), N,
                         nb_means=nbmu)
    fit = fit_vertex(prob, start=init_from_neighbour(prob, nb))
    assert fit.rel_err < 1e-6
    assert np.abs(fit.sigma[a] - sig[a]).max() < 1e-5      # lobe k stays lobe k (no flip)


def test_coherence_terms_smooth_the_view_field():
    """Noisy transport of a lobe fixed in the world (the truth is the same in every view): the
    mean/σ coherence terms cut the view-to-view jumps of the fitted means and σ, and fill the
    views below the horizon smoothly."""
    cube = light_cube(16)
    rng = np.random.default_rng(7)
    m0 = np.array([0.1, 0.9, 0.3]) / np.linalg.norm([0.1, 0.9, 0.3])
    mu = np.tile(m0, (92, 1, 1))
    sig = np.full((92, 1), 0.2)
    w = np.tile([1.0, 1.0, 1.0], (92, 1, 1))
    T = synthetic(cube, mu, sig, w)
    T = np.maximum(T + 0.1 * rng.normal(size=T.shape) * ACTIVE[:, None, None], 0.0)

    def jumps(fit, views):
        e = [(v, u) for v in views for u in NB[v, :CNT[v]] if u > v and u in views]
        return (np.mean([np.sum((fit.mu[v, 0] - fit.mu[u, 0]) ** 2) for v, u in e]),
                np.mean([(fit.sigma[v, 0] - fit.sigma[u, 0]) ** 2 for v, u in e]))

    plain = fit_vertex(VertexProblem(T, ACTIVE, cube.dirs, cube.omega,
                                     FitOptions(beta=0.0, gamma=0.0), N))
    coh = fit_vertex(VertexProblem(T, ACTIVE, cube.dirs, cube.omega,
                                   FitOptions(beta=20.0, gamma=20.0), N))
    act = set(np.flatnonzero(ACTIVE))
    jp, jc = jumps(plain, act), jumps(coh, act)
    assert jc[0] < 0.3 * jp[0] and jc[1] < 0.3 * jp[1], (jp, jc, plain.rel_err, coh.rel_err)
    # below the horizon the fill-in is smooth as well
    assert jumps(coh, set(range(92)))[0] < 0.3 * jumps(plain, set(range(92)))[0]
    # and the data fit barely pays for it
    assert coh.rel_err < plain.rel_err * 1.02


def test_weights_stay_nonnegative_at_a_kkt_point():
    """A lobe with a notch (T = G1 − 0.6 G2, clipped at zero): the unconstrained two-Gaussian
    fit cancels lobes with a negative weight. Projected LM keeps every weight ≥ 0 and stops at
    a KKT point of the bound: at w = 0 the gradient points into the bound (Jᵀr ≥ 0), elsewhere
    the gradient vanishes."""
    cube = light_cube(8)
    m = reflected()
    T = np.zeros((92, len(cube.dirs), 3))
    for v in np.flatnonzero(ACTIVE):
        notch = m[v] + 0.15 * np.cross(m[v], N)
        notch /= np.linalg.norm(notch)
        lobe = gaussian(cube.dirs, m[v], 0.35) - 0.6 * gaussian(cube.dirs, notch, 0.12)
        T[v] = np.maximum(lobe, 0.0)[:, None] * [1.0, 0.7, 0.4]
    opts = FitOptions(gaussians=2, beta=0.0, gamma=0.0, delta=0.0, max_iter=300, ftol=1e-12)
    prob = VertexProblem(T, ACTIVE, cube.dirs, cube.omega, opts, N)
    fit = fit_vertex(prob)
    assert (fit.w >= 0.0).all()
    _, _, _, g, _ = prob.evaluate(fit.mu, np.log(fit.sigma), fit.w, True)
    gw = np.stack([g[:, 3:6], g[:, 9:12]], axis=1)                    # (92, K, 3) ∂F/∂w / 2
    scale = np.abs(prob.evaluate(*init_params(prob), True)[3]).max()    # the start's gradient
    at_bound = fit.w[ACTIVE] == 0.0
    assert at_bound.any()                         # the bound is active somewhere in this test
    assert (gw[ACTIVE][at_bound] >= -1e-6 * scale).all()
    assert np.abs(gw[ACTIVE][~at_bound]).max() < 1e-4 * scale


def test_initial_weights_are_the_nonnegative_least_squares_optimum():
    """solve_weights against enumerating the active sets of two Gaussians (the NNLS optimum is
    the best feasible unconstrained solution over all subsets)."""
    cube = light_cube(8)
    rng = np.random.default_rng(5)
    mu = rng.normal(size=(2, 3))
    mu[1] = mu[0] + 0.1 * mu[1]                 # a narrower lobe inside the broad one
    mu /= np.linalg.norm(mu, axis=1, keepdims=True)
    sig = np.array([0.5, 0.2])
    G = np.stack([gaussian(cube.dirs, mu[k], sig[k]) for k in range(2)], axis=1)
    # channels 0 and 1: a lobe minus a narrower one (the unconstrained optimum is negative)
    T = np.maximum(G @ np.array([[1.0, 1.0, 0.3], [-0.6, -0.3, 0.2]])
                   + 0.05 * rng.normal(size=(len(cube.dirs), 3)), 0.0)
    A = G * np.sqrt(cube.omega)[:, None]
    free = np.linalg.lstsq(A, T * np.sqrt(cube.omega)[:, None], rcond=None)[0]
    assert (free < 0).any()                    # the bound matters in this test
    w = solve_weights(T, cube.dirs, cube.omega, mu, sig)
    assert (w >= 0).all()

    def cost(wc, c):
        return np.sum(cube.omega * (G @ wc - T[:, c]) ** 2)

    for c in range(3):
        best = cost(np.zeros(2), c)
        for keep in ([0], [1], [0, 1]):
            A = G[:, keep] * np.sqrt(cube.omega)[:, None]
            x = np.linalg.lstsq(A, T[:, c] * np.sqrt(cube.omega), rcond=None)[0]
            if (x >= 0).all():
                full = np.zeros(2)
                full[keep] = x
                best = min(best, cost(full, c))
        assert cost(w[:, c], c) == pytest.approx(best, rel=1e-9)


@pytest.mark.parametrize("scale", [1e-170, 1e-300])
def test_init_survives_transport_in_the_far_tail_of_a_sharp_lobe(scale):
    """A view whose only transport is the deep tail of a sharp lobe (Beckmann α 0.1 reaches
    1e-170 at ~62° off its peak) must not break the start: ‖m‖² underflows to 0 there, and a
    mean direction divided by a floored norm became a vector of length 1e140 whose Gaussian
    overflowed exp and NNLS (a ball on a glossy floor crashed the transport stage)."""
    cube = light_cube(8)
    opts = FitOptions(gaussians=2)
    T = synthetic(cube, reflected()[:, None, :].repeat(2, 1), np.full((92, 2), 0.2),
                  np.ones((92, 2, 3)))
    tail = np.flatnonzero(ACTIVE)[3]
    T[tail] *= scale                          # one view: only the far tail of the lobe
    prob = VertexProblem(T, ACTIVE, cube.dirs, cube.omega, opts, N)
    with np.errstate(over="raise", invalid="raise"):
        mu, s, w = init_params(prob)
    assert np.isfinite(mu).all() and np.isfinite(s).all() and np.isfinite(w).all()
    assert np.allclose(np.linalg.norm(mu, axis=-1), 1.0)
    assert (w[tail] <= 1e-100).all()
    fit = fit_vertex(prob, (mu, s, w))
    assert np.isfinite(fit.w).all() and fit.rel_err < 0.05
    # and the whole vertex in the tail: no data worth fitting, zero weights, no error
    tiny = VertexProblem(T * 1e-160, ACTIVE, cube.dirs, cube.omega, opts, N)
    with np.errstate(over="raise", invalid="raise"):
        fit = fit_vertex(tiny)
    assert np.isfinite(fit.mu).all() and np.isfinite(fit.w).all()
