"""Han07 §7, the vMF method: a mixture of J vMF lobes per texel per MIP level fitted by
spherical EM (Algorithm 1) to all the normals the texel covers, stored as the textures α_j and
α_j·r_j that stay valid under trilinear interpolation (§7.3: α̃ = T(α), r̃ = T(αr)/T(α)), and
the per-lookup recovery of κ and μ (Algorithm 2 lines 7–10) that the render kernel mirrors.

Fitting runs fine → coarse (pass 1: level 0 is one delta lobe per texel; each coarser texel
starts from the Hochbaum–Shmoys choice among its four children's lobes), then coarse → fine
(pass 2, when aligned: in scan-line order each texel's lobes are permuted into the slots of its
coarser parent and previously visited neighbours, then a few EM iterations with the eq 23
alignment pull towards those neighbours run for all texels of the level at once)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from sgpipe.normalmap import _vmf_jit as jit
from sgpipe.normalmap.lobes import kappa_of_rbar, rbar_of_kappa
from sgpipe.normalmap.pyramid import level_count


@dataclass
class VMFSettings:
    lobes: int = 4
    levels: int | None = None
    align: bool = True
    align_strength: float = 1.0
    max_iter: int = 20
    align_iter: int = 5
    tol: float = 1e-5
    kappa_max: float = 1e4


@dataclass
class VMFPyramid:
    """Per level ℓ (side n/2^ℓ): alpha[ℓ] (m, m, J) and alpha_r[ℓ] (m, m, J, 3), float32; with
    features, alpha_f[ℓ] (m, m, J, F) = α_j × lobe j's feature vector (Han07 eq 22: linear in
    the NDF like α·r, so a lookup recovers a lobe's features as T(αf)/T(α))."""

    alpha: list
    alpha_r: list
    alpha_f: list | None = None

    @property
    def lobes(self) -> int:
        return int(self.alpha[0].shape[2])


def _textures(alpha, mu, rbar, feat):
    """(α, α·r, α·f) float32 of lobe parameters, r = rbar · μ, f the lobe's features (§7.3: the
    quantities linear in γ)."""
    ar = (alpha * rbar)[..., None] * mu
    return alpha.astype(np.float32), ar.astype(np.float32), (alpha[..., None] * feat).astype(
        np.float32)


def _level0_textures(normals, slot, k_n, rbar_max, features):
    n = normals.shape[0]
    alpha = np.zeros((n, n, k_n), np.float32)
    ar = np.zeros((n, n, k_n, 3), np.float32)
    af = np.zeros((n, n, k_n, features.shape[2]), np.float32)
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    alpha[ii, jj, slot] = 1.0
    ar[ii, jj, slot] = (rbar_max * normals).astype(np.float32)
    af[ii, jj, slot] = features.astype(np.float32)
    return alpha, ar, af


def fit_vmf_pyramid(normals: np.ndarray, settings: VMFSettings = VMFSettings(),
                    progress=None, fine: np.ndarray | None = None,
                    features: np.ndarray | None = None) -> VMFPyramid:
    """The vMF textures of every level of a (n, n, 3) unit normal map. With `fine` (n·s, n·s,
    3), the unit normals of s × s sub-samples per texel (`bilinear.bilinear_normals`), the
    levels ≥ 1 are fitted to those instead (level ℓ: the (2^ℓ s)² sub-samples of a texel; the
    log2 s sub-sample levels below are fitted in pass 1 only, for the Hochbaum–Shmoys
    candidates); level 0 stays the map. `features` (n, n, F): a feature vector per texel
    (colour, material parameters; each sub-sample takes its texel's), whose responsibility-
    weighted mean each lobe carries (Han07 eq 22; VMFPyramid.alpha_f). `progress(step, what)`
    is called after each level of each pass (for a progress bar)."""
    s = settings
    normals = np.ascontiguousarray(normals, np.float64)
    n = normals.shape[0]
    src = normals if fine is None else np.ascontiguousarray(fine, np.float64)
    shift = (src.shape[0] // n).bit_length() - 1    # sub-sample levels below level 0
    if src.shape[0] != n << shift:
        raise ValueError(f"sub-sample map side {src.shape[0]} is not {n}·2^k")
    with_f = features is not None
    f0 = (np.zeros((n, n, 0)) if features is None
          else np.ascontiguousarray(features, np.float64))
    if f0.shape[:2] != (n, n):
        raise ValueError(f"features have shape {f0.shape}, expected ({n}, {n}, F)")
    fsrc = np.ascontiguousarray(np.repeat(np.repeat(f0, 1 << shift, 0), 1 << shift, 1))
    n_f = f0.shape[2]
    k_n = int(s.lobes)
    n_lev = level_count(n, s.levels)
    rbar_max = rbar_of_kappa(s.kappa_max)
    dummy_a = np.zeros((1, 1, k_n))
    dummy_m = np.zeros((1, 1, k_n, 3))
    dummy_f = np.zeros((1, 1, k_n, n_f))
    fits = [None]                                   # index: level of src; 0 is src itself
    for lev in range(1, n_lev + shift):             # pass 1, fine → coarse
        m = src.shape[0] >> lev
        a, mu, ka, rb = (np.zeros((m, m, k_n)), np.zeros((m, m, k_n, 3)),
                         np.zeros((m, m, k_n)), np.zeros((m, m, k_n)))
        ft = np.zeros((m, m, k_n, n_f))
        c = fits[-1]
        ca, cmu, crb = c[:3] if c else (dummy_a, dummy_m, dummy_a)
        jit.fit_level(src, fsrc, lev, False, ca, cmu, crb, c is None, dummy_a, dummy_m,
                      dummy_a, dummy_f, dummy_a, dummy_m, False, a, mu, ka, rb, ft, 0.0,
                      s.max_iter, s.tol, s.kappa_max)
        fits.append((a, mu, rb, ka, ft))
        if lev <= shift:
            fits[lev - 1] = None                    # a sub-sample level: only its parent needs it
        if progress:
            progress(1, f"level {lev - shift} EM")
    fits = [None] + fits[1 + shift:]                # index: level of the map
    if not s.align:
        alpha = [_level0_textures(normals, np.zeros((n, n), np.int64), k_n, rbar_max, f0)]
        alpha += [_textures(f[0], f[1], f[2], f[4]) for f in fits[1:]]
        return VMFPyramid([t[0] for t in alpha], [t[1] for t in alpha],
                          [t[2] for t in alpha] if with_f else None)
    out = [None] * n_lev
    parent = None
    for lev in range(n_lev - 1, 0, -1):             # pass 2, coarse → fine
        ua, umu, _, uka, uft = fits[lev]
        m = n >> lev
        a, mu, ka, rb = (np.zeros((m, m, k_n)), np.zeros((m, m, k_n, 3)),
                         np.zeros((m, m, k_n)), np.zeros((m, m, k_n)))
        ft = np.zeros((m, m, k_n, n_f))
        pa, pm = parent if parent is not None else (dummy_a, dummy_m)
        ma, mmu, mka, mft = (np.zeros_like(a), np.zeros_like(mu), np.zeros_like(ka),
                             np.zeros_like(ft))
        jit.match_level(ua, umu, uka, uft, pa, pm, parent is not None, ma, mmu, mka, mft)
        jit.fit_level(src, fsrc, lev + shift, True, dummy_a, dummy_m, dummy_a, False, ma, mmu,
                      mka, mft, pa, pm, parent is not None, a, mu, ka, rb, ft,
                      float(s.align_strength), s.align_iter, s.tol, s.kappa_max)
        out[lev] = _textures(a, mu, rb, ft)
        parent = (a, mu)
        fits[lev] = None                            # free pass-1 memory as we go
        if progress:
            progress(1, f"level {lev} aligned")
    slot = np.zeros((n, n), np.int64)
    pa, pm = parent if parent is not None else (dummy_a, dummy_m)
    jit.align_level0(normals, pa, pm, parent is not None, k_n, slot)
    out[0] = _level0_textures(normals, slot, k_n, rbar_max, f0)
    return VMFPyramid([t[0] for t in out], [t[1] for t in out],
                      [t[2] for t in out] if with_f else None)


def progress_steps(side: int, settings: VMFSettings, subsamples: int = 1) -> int:
    """How many times `fit_vmf_pyramid` calls `progress` (`subsamples`: s of `fine`)."""
    n_lev = level_count(side, settings.levels)
    return (n_lev - 1) * (2 if settings.align else 1) + (int(subsamples).bit_length() - 1)


# -- lookup (Algorithm 2 lines 5–10; the render kernel mirrors these) ---------------------------

@njit(cache=True)
def lobe_from_texel(alpha, ar0, ar1, ar2):
    """(α, μ (3,), κ) of one interpolated texel value: r = αr/α, κ = (3|r| − |r|³)/(1 − |r|²),
    μ = r/|r| (Algorithm 2 lines 7–10); an empty lobe (α ≤ 0) returns κ = 0."""
    mu = np.zeros(3)
    if alpha <= 0.0:
        mu[2] = 1.0
        return 0.0, mu, 0.0
    r0, r1, r2 = ar0 / alpha, ar1 / alpha, ar2 / alpha
    rl = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    if rl <= 0.0:
        mu[2] = 1.0
        return alpha, mu, 0.0
    mu[0], mu[1], mu[2] = r0 / rl, r1 / rl, r2 / rl
    return alpha, mu, kappa_of_rbar(rl)


@njit(cache=True)
def bilinear(tex, u, v):
    """Bilinear fetch of a (m, m, C) texture at (u, v) with sgpipe's addressing (repeat, v = 0
    the bottom row, texel centres at half-integers: render/kernels/include/shading.h)."""
    m = tex.shape[0]
    x = (u - math.floor(u)) * m - 0.5
    y = (1.0 - (v - math.floor(v))) * m - 0.5
    x0f, y0f = math.floor(x), math.floor(y)
    fx, fy = x - x0f, y - y0f
    x0 = int(x0f) % m
    y0 = int(y0f) % m
    x1, y1 = (x0 + 1) % m, (y0 + 1) % m
    out = np.empty(tex.shape[2])
    for c in range(tex.shape[2]):
        a = tex[y0, x0, c] * (1 - fx) + tex[y0, x1, c] * fx
        b = tex[y1, x0, c] * (1 - fx) + tex[y1, x1, c] * fx
        out[c] = a * (1 - fy) + b * fy
    return out


def lookup(pyr: VMFPyramid, u: float, v: float, lod: float):
    """Trilinear lookup of every lobe at (u, v) and level `lod` (clamped to the pyramid):
    interpolate α and αr (valid because they are linear in the NDF), then recover κ and μ.
    Returns (alpha (J,), mu (J, 3), kappa (J,))."""
    lod = min(max(float(lod), 0.0), len(pyr.alpha) - 1.0)
    l0 = int(math.floor(lod))
    l1 = min(l0 + 1, len(pyr.alpha) - 1)
    f = lod - l0
    k_n = pyr.lobes

    def fetch(lev):
        tex = np.concatenate([pyr.alpha[lev][..., None], pyr.alpha_r[lev]], axis=3)
        return bilinear(tex.reshape(tex.shape[0], tex.shape[1], -1).astype(np.float64),
                        u, v).reshape(k_n, 4)

    t = fetch(l0) * (1 - f) + (fetch(l1) * f if f > 0 else 0.0)
    al, mu, ka = np.zeros(k_n), np.zeros((k_n, 3)), np.zeros(k_n)
    for j in range(k_n):
        al[j], mu[j], ka[j] = lobe_from_texel(t[j, 0], t[j, 1], t[j, 2], t[j, 3])
    return al, mu, ka


def lookup_features(pyr: VMFPyramid, u: float, v: float, lod: float) -> np.ndarray:
    """Each lobe's feature vector (J, F) at a trilinear lookup: T(α·f)/T(α), as `lookup`
    recovers μ and κ from T(α·r)/T(α) (0 for an empty lobe)."""
    lod = min(max(float(lod), 0.0), len(pyr.alpha) - 1.0)
    l0 = int(math.floor(lod))
    l1 = min(l0 + 1, len(pyr.alpha) - 1)
    f = lod - l0
    k_n, n_f = pyr.lobes, pyr.alpha_f[0].shape[3]

    def fetch(lev):
        tex = np.concatenate([pyr.alpha[lev][..., None], pyr.alpha_f[lev]], axis=3)
        return bilinear(tex.reshape(tex.shape[0], tex.shape[1], -1).astype(np.float64),
                        u, v).reshape(k_n, 1 + n_f)

    t = fetch(l0) * (1 - f) + (fetch(l1) * f if f > 0 else 0.0)
    a = t[:, :1]
    return np.where(a > 0, t[:, 1:] / np.where(a > 0, a, 1.0), 0.0)


def texel_lobes(pyr: VMFPyramid, level: int, row: int, col: int):
    """(alpha (J,), mu (J, 3), kappa (J,)) stored at one texel."""
    a = pyr.alpha[level][row, col].astype(np.float64)
    ar = pyr.alpha_r[level][row, col].astype(np.float64)
    out = [lobe_from_texel(a[j], ar[j, 0], ar[j, 1], ar[j, 2]) for j in range(len(a))]
    return (np.array([o[0] for o in out]), np.array([o[1] for o in out]),
            np.array([o[2] for o in out]))


def mixture_blinn_phong(alpha, mu, kappa, s: float, omega_h) -> np.ndarray:
    """Σ_j α_j (s′+1)/(2π) (ω_h·μ_j)^{s′}, s′ = κ_j s/(κ_j + s) (eq 20, Algorithm 2 lines 12–13
    without the cosine and colour terms) at directions omega_h (..., 3)."""
    omega_h = np.asarray(omega_h, float)
    out = np.zeros(omega_h.shape[:-1])
    for a, m, k in zip(alpha, mu, kappa):
        if a <= 0 or k <= 0:
            continue
        sp = k * s / (k + s)
        out += a * (sp + 1) / (2 * math.pi) * np.maximum(omega_h @ m, 0.0) ** sp
    return out


def mixture_zonal(alpha, mu, kappa, rho_hat, omega) -> np.ndarray:
    """Han07 eq 14 for any radially symmetric BRDF (measured ones included): Σ_j α_j Σ_l ρ̂_l
    g_l(κ_j) (2l+1)/(4π) P_l(ω·μ_j), with the exact vMF coefficients g_l = Λ_l γ_l =
    i_l(κ)/i_0(κ) (`lobes.vmf_zonal_exact`) at directions omega (..., 3)."""
    from scipy.special import eval_legendre

    from sgpipe.normalmap.lobes import vmf_zonal_exact
    rho_hat = np.asarray(rho_hat, float)
    lmax = len(rho_hat) - 1
    l = np.arange(lmax + 1)
    omega = np.asarray(omega, float)
    out = np.zeros(omega.shape[:-1])
    for a, m, k in zip(alpha, mu, kappa):
        if a <= 0 or k <= 0:
            continue
        c = rho_hat * vmf_zonal_exact(k, lmax) * (2 * l + 1) / (4 * math.pi)
        u = np.clip(omega @ np.asarray(m, float), -1.0, 1.0)
        out += a * np.sum(c * eval_legendre(l, u[..., None]), axis=-1)
    return out
