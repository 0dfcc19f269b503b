"""`transport.sampling: lobe` — Green06 eq 2's transport sampled where the BRDF lobe is, and each
view's Gaussians (eq 4) set from those samples.

The published fit (`sampling: cube`, `fit.py`) samples T_{x,v} at the centres of a fixed light
cube, so a lobe narrower than a light texel (GGX α 0.08 at 6×16²: one texel is 5.6°) loses its
energy between the centres. Here every active view draws `n` directions from its own specular
lobe (the same stratified rank-1 lattice in (u1, u2) for every view and vertex, so the result is
deterministic and smooth across views), traces one occlusion ray per direction, and weights it
by f_s cos V / p. Each view's Gaussians G(ω) = exp((ω·μ − 1)/σ²) share the transport's mean
direction μ and carry its integral (per colour channel) exactly; their σ (one lobe, a core and
a wider halo for long-tailed lobes, three sub-lobes along a stretched lobe, or both) minimise
the L2 distance to the transport under that constraint. Where a rim or a neighbour clips the
lobe, the traced samples move μ into the visible part and narrow σ; the integral stays the
visible transport's. Paths of
`transport.indirect` that leave the scene join the samples with their throughputs (eq 5), so
T^IG enters the same integral and mean.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from sgpipe.core.sphere import to_local, to_world
from sgpipe.transport.interp import lobe_area
from sgpipe.transport.sampling import vertex_visibility

#: 1/φ, the golden-ratio step of the rank-1 lattice
_INV_PHI = (np.sqrt(5.0) - 1.0) / 2.0


@lru_cache(maxsize=8)
def lattice(n: int) -> tuple[np.ndarray, np.ndarray]:
    """(u1, u2) of a rank-1 (Fibonacci) lattice of n points in [0, 1)²: u1 stratified, u2 the
    golden-ratio sequence; one fixed set, so neighbouring views and vertices see the same
    quadrature."""
    i = np.arange(n, dtype=np.float64)
    u1, u2 = (i + 0.5) / n, np.mod(0.5 + i * _INV_PHI, 1.0)
    u1.setflags(write=False)
    u2.setflags(write=False)
    return u1, u2


#: views down to this cos below a vertex's horizon get Gaussians (of their view raised to the
#: horizon, `raised_views`): the triangles of views that straddle the horizon blend them
EXTRAPOLATE_COS = -0.5


def raised_views(views, normal, tangent, min_cos: float):
    """The views with n·v < min_cos turned about the horizon up to n·v = min_cos (straight
    below the vertex: towards the tangent). Near the horizon a query view's three nearest
    views include views below it; the lobe of the view raised to the horizon continues the
    above-horizon field there, where zero weights would fade the integral (to 0.2 of it at
    8° elevation for a Beckmann α 0.08 lobe) and copied means would swing the blended mean by
    10°."""
    c = views @ normal
    tng = views - c[:, None] * normal
    ln = np.linalg.norm(tng, axis=1, keepdims=True)
    tng = np.where(ln > 1e-9, tng / np.maximum(ln, 1e-300), tangent)
    s = min(max(min_cos, 0.0), 1.0)
    up = tng * np.sqrt(1.0 - s * s) + np.asarray(normal) * s
    return np.where((c < min_cos)[:, None], up, views)


def lobe_samples(brdf, normal, tangent, bitangent, views, active, n: int):
    """Directions (A, n, 3) world, estimator weights (A, n, 3) = f_s cos q and q = 1 / (n p)
    (A, n) of each active view's specular lobe, unshadowed (zero where the sample failed or
    fell below the surface); Σ_s weight_s g(ω_s) estimates ∫ f_s cos g dω."""
    act = np.flatnonzero(active)
    u1, u2 = lattice(n)
    o = to_local(views[act], normal, tangent, bitangent)[:, None, :]           # (A, 1, 3)
    o = np.broadcast_to(o, (len(act), n, 3))
    i_loc, p = brdf.sample(o, u1[None, :], u2[None, :], lobe="specular")
    ok = (p > 0) & (i_loc[..., 2] > 0)
    f = brdf.specular(o, i_loc)
    q = np.where(ok, 1.0 / (n * np.where(ok, p, 1.0)), 0.0)
    wgt = f * (np.maximum(i_loc[..., 2], 0.0) * q)[..., None]
    return to_world(i_loc, normal, tangent, bitangent), wgt, q


def shadow_samples(scene, position, normal, dirs, wgt, offset: float) -> np.ndarray:
    """The weights with occluded directions zeroed: the light cube's `vertex_visibility` (one
    Embree occlusion ray from `offset` along the normal) for every sample that carries
    weight."""
    live = np.flatnonzero((wgt > 0).any(-1).ravel())
    if scene is None or not len(live):
        return wgt
    out = wgt.reshape(-1, 3).copy()
    seen = vertex_visibility(scene, position, normal, dirs.reshape(-1, 3)[live], offset)
    out[live[~seen]] = 0.0
    return out.reshape(wgt.shape)


#: σ candidates per octave of the shape search (`lobe_gaussians`)
SIGMA_STEPS_PER_OCTAVE = 8
#: σ_halo / σ_core ratios the two-Gaussian search tries
HALO_RATIOS = (1.5, 2.0, 3.0, 4.0, 6.0, 8.0)


def _sg_product_integral(mu1, s1, mu2, s2):
    """∫ G(·; μ1, σ1) G(·; μ2, σ2) dω = 2π e^{r − λ1 − λ2} (1 − e^{−2r}) / r,
    r = ‖λ1 μ1 + λ2 μ2‖, λ = 1/σ² (the SG inner product)."""
    l1, l2 = 1.0 / np.asarray(s1, float) ** 2, 1.0 / np.asarray(s2, float) ** 2
    r = np.linalg.norm(l1[..., None] * mu1 + l2[..., None] * mu2, axis=-1)
    # (1 − e^{−2r}) / r → 2 as r → 0 (equal lobes pointing apart)
    ratio = np.where(r > 1e-12, -np.expm1(-2.0 * r) / np.maximum(r, 1e-12), 2.0)
    return 2.0 * np.pi * np.exp(r - l1 - l2) * ratio


def _self_integral(s1, s2):
    """∫ G(·; μ, s1) G(·; μ, s2) dω = 2π A(σ) with 1/σ² = 1/s1² + 1/s2²."""
    return 2.0 * np.pi * lobe_area(1.0 / np.sqrt(1.0 / s1 ** 2 + 1.0 / s2 ** 2))


def _best_shapes(c, lum, E, grid, k: int):
    """Indices (A, k) into grid and the core's share t (A,) of the view's integral E: the
    Gaussians about the view's mean (cos − 1 per sample c (A, S), sample luminance weights
    lum) that carry E together and are closest to the transport in L2 over the sphere,
    ‖Σ w_i G_i − T‖² = wᵀ M w − 2 wᵀ b + ∫T² with M exact (`_self_integral`) and
    b_i = ∫ G_i T = Σ_s G_i(ω_s) lum_s."""
    b = np.stack([np.einsum("as,as->a", np.exp(np.minimum(c, 0.0) / (sg * sg)), lum)
                  for sg in grid], -1)                                    # (A, G)
    area = 2.0 * np.pi * lobe_area(grid)                                  # (G,)
    if k == 1:
        w = E[:, None] / area[None, :]
        err = w * w * _self_integral(grid, grid)[None, :] - 2.0 * w * b
        return np.argmin(err, axis=1)[:, None], np.ones(len(E))
    steps = np.log2(np.asarray(HALO_RATIOS)) * SIGMA_STEPS_PER_OCTAVE
    i1, j = np.meshgrid(np.arange(len(grid)), np.rint(steps).astype(int), indexing="ij")
    i2 = i1 + j
    keep = i2 < len(grid)
    i1, i2 = i1[keep], i2[keep]                                           # (P,) pairs
    s1, s2 = grid[i1], grid[i2]
    m11, m22, m12 = _self_integral(s1, s1), _self_integral(s2, s2), _self_integral(s1, s2)
    # w1 = t E / a1, w2 = (1 − t) E / a2; the error is a quadratic in t, minimised on [0, 1]
    u1, u2 = E[:, None] / area[i1][None, :], E[:, None] / area[i2][None, :]   # (A, P)
    qa = u1 * u1 * m11 - 2.0 * u1 * u2 * m12 + u2 * u2 * m22
    qb = 2.0 * (u1 * u2 * m12 - u2 * u2 * m22) - 2.0 * (u1 * b[:, i1] - u2 * b[:, i2])
    t = np.clip(np.where(qa > 0, -qb / (2.0 * np.where(qa > 0, qa, 1.0)), 1.0), 0.0, 1.0)
    w1, w2 = t * u1, (1.0 - t) * u2
    err = w1 * w1 * m11 + 2.0 * w1 * w2 * m12 + w2 * w2 * m22 - 2.0 * (w1 * b[:, i1]
                                                                     + w2 * b[:, i2])
    best = np.argmin(err, axis=1)
    rows = np.arange(len(E))
    return np.stack([i1[best], i2[best]], -1), t[rows, best]


#: the largest offset of the outer sub-lobes, in units of the sub-lobes' σ (beyond it three
#: Gaussians no longer sum to one hump)
MAX_SUBLOBE_OFFSET = 2.0


def sublobe_axes(c_dirs, lum, axis, normal):
    """Per view the direction e (A, 3) in which the transport about `axis` is longest and its
    aspect ratio ρ = √(λ_max / λ_min) (A,) of the samples' luminance-weighted covariance in
    the tangent plane of the axis; e is turned towards the normal (n·e ≥ 0) so that
    neighbouring views order their sub-lobes alike."""
    t1 = np.cross(axis, np.where(np.abs(axis[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]],
                                 [[1.0, 0.0, 0.0]]))
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(axis, t1)
    x, y = np.einsum("asc,ac->as", c_dirs, t1), np.einsum("asc,ac->as", c_dirs, t2)
    tot = np.maximum(lum.sum(1), 1e-300)
    cxx, cyy, cxy = ((lum * x * x).sum(1) / tot, (lum * y * y).sum(1) / tot,
                     (lum * x * y).sum(1) / tot)
    half_tr, det = 0.5 * (cxx + cyy), cxx * cyy - cxy * cxy
    disc = np.sqrt(np.maximum(half_tr * half_tr - det, 0.0))
    lmax, lmin = half_tr + disc, np.maximum(half_tr - disc, 1e-300)
    # eigenvector of λ_max: (cxy, λ_max − cxx), or (λ_max − cyy, cxy) when that one vanishes
    ex = np.where(np.abs(cxy) > 1e-300, cxy, np.where(cxx >= cyy, 1.0, 0.0))
    ey = np.where(np.abs(cxy) > 1e-300, lmax - cxx, np.where(cxx >= cyy, 0.0, 1.0))
    e = ex[:, None] * t1 + ey[:, None] * t2
    e /= np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-300)
    e *= np.where(e @ normal < 0, -1.0, 1.0)[:, None]
    return e, np.sqrt(lmax / lmin)


def _sublobe_dirs(axis, e, d):
    """(A, 3, 3) directions of three sub-lobes: the axis turned by −d, 0, +d towards e."""
    cd, sd = np.cos(d)[:, None], np.sin(d)[:, None]
    return np.stack([axis * cd - e * sd, axis, axis * cd + e * sd], 1)


def _best_sublobes(c_dirs, lum, E, axis, e, rho, grid, halo: bool):
    """Per view (σ (A,), offset d (A,), halo σ (A,), halo share (A,)) of three equal-share
    sub-lobes along e (sub-lobe σ, offsets ±d with the along/across spread ratio ρ:
    σ² + (2/3) d² = ρ² σ², d ≤ MAX_SUBLOBE_OFFSET σ), with `halo` plus one wider Gaussian
    about the axis (σ ratio from HALO_RATIOS) taking a share h of the integral, that carry E
    together and are closest to the transport in L2: with F1 the sub-lobes and F2 the halo
    each of unit integral, ‖E((1 − h) F1 + h F2) − T‖² is a quadratic in h."""
    A = len(E)
    best = [np.full(A, grid[-1]), np.zeros(A), np.full(A, grid[-1]), np.zeros(A)]
    best_err = np.full(A, np.inf)
    ratio = np.minimum(np.sqrt(1.5 * np.maximum(rho * rho - 1.0, 0.0)), MAX_SUBLOBE_OFFSET)
    steps = np.rint(np.log2(np.asarray(HALO_RATIOS)) * SIGMA_STEPS_PER_OCTAVE).astype(int)
    g_halo = [np.exp(np.minimum(np.einsum("asc,ac->as", c_dirs, axis) - 1.0, 0.0) / (sg * sg))
              for sg in grid] if halo else None
    for gi, sg in enumerate(grid):
        d = ratio * sg
        mus = _sublobe_dirs(axis, e, d)                                   # (A, 3, 3)
        a1 = 3.0 * 2.0 * np.pi * lobe_area(sg)       # F1 = Σ G_k / a1 has unit integral
        m11 = sum(_sg_product_integral(mus[:, i], sg, mus[:, j], sg)
                  for i in range(3) for j in range(3)) / (a1 * a1)
        g = np.exp(np.minimum(np.einsum("asc,akc->ask", c_dirs, mus) - 1.0, 0.0) / (sg * sg))
        b1 = np.einsum("ask,as->a", g, lum) / a1
        err = E * E * m11 - 2.0 * E * b1
        better = err < best_err
        for arr, val in zip(best, (sg, d, grid[-1], 0.0)):
            arr[better] = val if np.ndim(val) == 0 else val[better]
        best_err[better] = err[better]
        for st in (steps if halo else ()):
            hi = gi + st
            if hi >= len(grid):
                break
            sh = grid[hi]
            a2 = 2.0 * np.pi * lobe_area(sh)
            m22 = _sg_product_integral(axis, sh, axis, sh) / (a2 * a2)
            m12 = sum(_sg_product_integral(mus[:, i], sg, axis, sh) for i in range(3)) / (a1 * a2)
            b2 = np.einsum("as,as->a", g_halo[hi], lum) / a2
            # E²((1−h)² m11 + 2h(1−h) m12 + h² m22) − 2E((1−h) b1 + h b2), minimised in h
            qa = E * E * (m11 - 2.0 * m12 + m22)
            qb = 2.0 * E * E * (m12 - m11) - 2.0 * E * (b2 - b1)
            h = np.clip(np.where(qa > 0, -qb / (2.0 * np.where(qa > 0, qa, 1.0)), 0.0), 0.0, 1.0)
            err = (E * E * ((1 - h) ** 2 * m11 + 2 * h * (1 - h) * m12 + h * h * m22)
                   - 2.0 * E * ((1 - h) * b1 + h * b2))
            better = err < best_err
            for arr, val in zip(best, (sg, d, sh, h)):
                arr[better] = val if np.ndim(val) == 0 else val[better]
            best_err[better] = err[better]
    return tuple(best)


def lobe_gaussians(dirs, wgt, views, active, sigma_min: float, sigma_max: float,
                   k: int = 1, normal=None):
    """k Gaussians per view (mu (V, k, 3), sigma (V, k), w (V, k, 3)) about the samples' mean
    direction that carry the samples' integral (per colour channel) and are closest to the
    transport in L2 under that constraint: k = 1 one lobe; k = 2 a core and a wider halo
    (σ ratio from HALO_RATIOS), as a GGX lobe's long tails need; k = 3 three sub-lobes along
    the direction the transport is longest in (`sublobe_axes`; oblique views stretch a
    microfacet lobe, anisotropic BRDFs more); k = 4 those three and a halo. σ from a log grid
    (SIGMA_STEPS_PER_OCTAVE); dirs (A, S, 3) and wgt (A, S, 3) are the active views'
    samples. Views without transport (and inactive ones) take the nearest view's μ and σ with
    weight zero, so interpolation towards them fades the integral."""
    V = len(views)
    mu, sig, w = np.zeros((V, k, 3)), np.full((V, k), sigma_max), np.zeros((V, k, 3))
    act = np.flatnonzero(active)
    lum = wgt.mean(-1)                                               # (A, S)
    tot = lum.sum(-1)                                                # (A,)
    m = np.einsum("as,asc->ac", lum, dirs)
    norm = np.linalg.norm(m, axis=-1)
    has = (tot > 0) & (norm > 0)
    good = act[has]
    if len(good):
        n_grid = int(np.ceil(np.log2(sigma_max / sigma_min) * SIGMA_STEPS_PER_OCTAVE)) + 1
        grid = np.geomspace(sigma_min, sigma_max, n_grid)
        axis = m[has] / norm[has, None]
        c = np.einsum("asc,ac->as", dirs[has], axis) - 1.0
        integral = wgt[has].sum(1)                                   # (G, 3)
        if k >= 3:
            e, rho = sublobe_axes(dirs[has], lum[has], axis, np.asarray(normal, float))
            s3, d, s_h, h = _best_sublobes(dirs[has], lum[has], tot[has], axis, e, rho, grid,
                                           k == 4)
            mu[good, :3] = _sublobe_dirs(axis, e, d)
            sig[good, :3] = s3[:, None]
            w[good, :3] = (integral * ((1.0 - h) / (3.0 * 2.0 * np.pi * lobe_area(s3)))[:, None]
                           )[:, None, :]
            if k == 4:
                mu[good, 3], sig[good, 3] = axis, s_h
                w[good, 3] = integral * (h / (2.0 * np.pi * lobe_area(s_h)))[:, None]
        else:
            idx, t = _best_shapes(c, lum[has], tot[has], grid, k)
            share = np.stack([t, 1.0 - t], -1)[:, :k]                # (G, k)
            mu[good] = axis[:, None, :]
            sig[good] = grid[idx]
            w[good] = (share[..., None] * integral[:, None, :]
                       / (2.0 * np.pi * lobe_area(grid[idx]))[..., None])
        for v in np.setdiff1d(np.arange(V), good):
            near = good[np.argmax(views[good] @ views[v])]
            mu[v], sig[v] = mu[near], sig[near]
    else:
        mu[:] = views[:, None, :]
    return mu, sig, w


def sample_error(dirs, wgt, q, mu, sigma, w, active) -> float:
    """Relative L2 error of the Gaussians against the transport, pooled over the active views
    like `fit.relative_error`: √(Σ_v ‖G̃ − T‖² / Σ_v ‖T‖²) with ‖G̃‖² exact, ∫G̃ T from the
    samples and ∫T² ≈ Σ_s T_s² q_s (q_s = 1 / (n p_s), T_s = wgt_s / q_s): the L2 distance
    `lobe_gaussians` minimises."""
    act = np.flatnonzero(active)
    m, sg, ww = mu[act], sigma[act], w[act]
    k = m.shape[1]
    gg = sum(np.einsum("ac,ac->a", ww[:, i], ww[:, j])
             * _sg_product_integral(m[:, i], sg[:, i], m[:, j], sg[:, j])
             for i in range(k) for j in range(k))
    g = np.exp(np.minimum(np.einsum("asc,akc->ask", dirs, m) - 1.0, 0.0) / sg[:, None, :] ** 2)
    gt = np.einsum("ask,akc,asc->a", g, ww, wgt)
    live = q > 0
    tt = np.where(live[..., None], wgt ** 2 / np.where(live, q, 1.0)[..., None], 0.0).sum((1, 2))
    den = float(tt.sum())
    return float(np.sqrt(max(float((gg - 2.0 * gt + tt).sum()), 0.0) / den)) if den > 0 else 0.0


__all__ = ["lattice", "lobe_samples", "shadow_samples",
           "sublobe_axes", "lobe_gaussians", "sample_error"]
