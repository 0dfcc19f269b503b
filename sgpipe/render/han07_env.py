"""Han07 §8's environment lighting for `vmf_han07`: the map's radiance SH L_lm (eq 25) and the
reparameterised lighting L'_lm(ω_o) of eq 26 on a grid of view directions, l* = 8.

    sh8 = environment_sh8(env)          # (81 + VIEWS² · 81, 4) float32: the kernels' nm_env_sh8

Eq 26 integrates over the half vector: B(μ) = ∫ L'(ω_h) ρ_eff(ω_h · μ) dω_h with
L'(ω_h) = L(ω_i) · 4(ω_i · ω_h), ω_i the mirror of ω_o about ω_h. Its SH coefficients are taken
over the map's texels instead of over ω_h: dω_i = 4(ω_i · ω_h) dω_h, so
L'_lm(ω_o) = ∫ L(ω_i) Y_lm(normalize(ω_i + ω_o)) dω_i — every texel's energy counted once, a sun
included, however finely ω_h would have had to be sampled to find it. L' depends on the view; the
paper precomputes "a sparse set (typically, about 16 × 16) of rotated lighting coefficients and
interpolate[s] the shading": here VIEWS × VIEWS views at the cell centres of a (θ, φ) grid in the
map's frame (θ from +z), read bilinearly by the kernel (φ wraps, θ clamps).
"""

from __future__ import annotations

import numpy as np

from sgpipe.core.sh import sh_eval

#: l* of eq 25–26 (the paper's Fig 9: "spherical harmonics up to order 8")
LMAX = 8
NCOEF = (LMAX + 1) ** 2
#: views per side of the L' table (§8: "about 16 × 16")
VIEWS = 16
#: the finest face resolution of the box MIP chain the projections read (energy-preserving)
FACE_MAX = 64


def view_grid(n: int = VIEWS) -> np.ndarray:
    """(n, n, 3) map-frame unit views at the cell centres θ = (i + ½)π/n, φ = (j + ½)2π/n."""
    th = (np.arange(n) + 0.5) * np.pi / n
    ph = (np.arange(n) + 0.5) * 2.0 * np.pi / n
    st = np.sin(th)[:, None]
    return np.stack([st * np.cos(ph)[None, :], st * np.sin(ph)[None, :],
                     np.cos(th)[:, None] * np.ones((1, n))], -1)


def map_texels(env) -> tuple[np.ndarray, np.ndarray]:
    """(dirs (N, 3) map frame, radiance × solid angle (N, 3)) of the finest level of the
    environment's box MIP chain whose faces are at most FACE_MAX texels wide."""
    from sgpipe.core.maps import cubemap_solid_angles, image_to_faces
    from sgpipe.render.envdata import bordered_dirs
    res = [int(r) for r in env.mip.res]
    lev = next((k for k, r in enumerate(res) if r <= FACE_MAX), len(res) - 1)
    n = res[lev]
    faces = image_to_faces(np.asarray(env.mip.level(lev), np.float64))[:, 1:-1, 1:-1, :3]
    dirs = image_to_faces(bordered_dirs(n, 1))[:, 1:-1, 1:-1]
    w = cubemap_solid_angles(n)[..., None] * faces
    return dirs.reshape(-1, 3), w.reshape(-1, 3)


def radiance_sh(dirs: np.ndarray, weighted: np.ndarray, lmax: int = LMAX) -> np.ndarray:
    """L_lm = Σ_texels L Y_lm(ω) Δω (eq 25's lighting), (K, 3)."""
    return sh_eval(dirs, lmax).T @ weighted


def reparameterised_sh(dirs: np.ndarray, weighted: np.ndarray, views: np.ndarray,
                       lmax: int = LMAX) -> np.ndarray:
    """L'_lm(ω_o) = Σ_texels L Y_lm(normalize(ω_i + ω_o)) Δω per view (eq 26), (..., K, 3)."""
    v = np.asarray(views, np.float64).reshape(-1, 3)
    out = np.empty((len(v), (lmax + 1) ** 2, 3))
    for k, o in enumerate(v):
        h = dirs + o
        ln = np.linalg.norm(h, axis=1, keepdims=True)
        keep = ln[:, 0] > 1e-9            # ω_i = −ω_o: no half vector (a null set)
        out[k] = sh_eval(h[keep] / ln[keep], lmax).T @ weighted[keep]
    return out.reshape(np.shape(views)[:-1] + out.shape[1:])


def environment_sh8(env) -> np.ndarray:
    """The kernels' `nm_env_sh8` (float4 rows): L_lm (NCOEF rows), then L'_lm of view (i, j)
    at rows NCOEF·(1 + i·VIEWS + j) … — all in the map's frame (env_to_map), radiance as the
    map stores it (the kernels apply env_scale)."""
    dirs, w = map_texels(env)
    rows = np.zeros((NCOEF * (1 + VIEWS * VIEWS), 4), np.float32)
    rows[:NCOEF, :3] = radiance_sh(dirs, w)
    rows[NCOEF:, :3] = reparameterised_sh(dirs, w, view_grid()).reshape(-1, 3)
    return rows
