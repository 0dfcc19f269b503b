"""`sg`'s energy table for GGX materials: per view elevation, the exact directional albedo of the
specular lobe over what `sg`'s own lobes give in a white furnace (F ≡ 1), for the material's
fitted lobes and for each entry of its roughness grid (ndf_sg_rough.npz). The kernels scale the
environment's specular part by it (sg_specular.h), so that a uniform environment reflects the
BRDF's exact energy at every view.

    attach_energy(materials)       # sets Material.energy (NE, 4) / energy_grid (NE, R, 4)

A material whose fitted lobes include one near λ = 0 renders with its roughness grid's lobes at
its α instead (those of a textured pixel of that roughness), whose sharpness floor keeps the
response smooth in the view.

Such a material's sub-lobes also carry the warped lobe's exact mass (sg_specular.h spec_warp,
MAT_WARPN), so that the response the table divides by varies smoothly with the view.

Why: the warp of an NDF lobe into i-space (Wang09 eq 17–22) and M_o taken at each sub-lobe's
axis hold for lobes narrower than the hemisphere. A rough GGX lobe (α ≳ 0.25) spans it: at a
grazing view the warp's Jacobian amplitude 1/(o·g) overshoots and head-on M_o at the axis
times the expected cosine undershoots E[M_o cos] (white furnace, metal r 0.7: head-on 0.52
for 0.68, frame mean 0.77 for 0.70). The response is measured by running the `sg` kernel on a
synthetic furnace frame (one pixel per view and lobe set), so the table corrects exactly what
the kernel computes.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sgpipe.artifacts.fit import rough_lobes_at
from sgpipe.render.records import ENERGY_COS_MIN, ENERGY_VIEWS   # the kernels' table layout
#: G2 kinds of the GGX family (microfacet.h mf_g2): 3 separable Smith, 8 height-correlated
GGX_SHADOWING = (3, 8)


def view_cosines() -> np.ndarray:
    return np.linspace(ENERGY_COS_MIN, 1.0, ENERGY_VIEWS)


def exact_albedo(alpha: float, cos_o: np.ndarray, shadowing: int, n: int = 96) -> np.ndarray:
    """(len(cos_o), 2): ∫ ρ_s(o, i) (n·i) di for isotropic GGX of roughness α (D normalised,
    G2 of `shadowing`) with F ≡ 1 and with Schlick's F0 = 0 part F = (1 − o·h)⁵ (Schlick's F
    is F0 times the first plus 1 − F0 times the second), by quadrature over h:
    ∫ D(h) G2(o, i) F (o·h) / (n·o) dh, i = reflect(o, h); θ_h graded with α (t = tan θ_h / α on
    a Gauss–Legendre rule in atan t)."""
    x, wx = np.polynomial.legendre.leggauss(n)
    a = 0.5 * (x + 1.0) * (np.pi / 2)                       # atan(t) ∈ (0, π/2)
    wa = 0.5 * wx * (np.pi / 2)
    t = np.tan(a)
    th = np.arctan(alpha * t)
    # dθ_h = α (1 + t²) / (1 + α² t²) · da
    wth = wa * alpha * (1 + t * t) / (1 + alpha * alpha * t * t)
    ph, wph = np.polynomial.legendre.leggauss(2 * n)
    ph = 0.5 * (ph + 1.0) * np.pi                            # symmetric: φ ∈ (0, π), ×2
    wph = 0.5 * wph * np.pi * 2.0
    return _albedo_sums(th, wth, ph, wph, float(alpha), np.asarray(cos_o, np.float64),
                        int(shadowing))


@njit(cache=True)
def _albedo_sums(th, wth, ph, wph, alpha, cos_o, kind):
    """The quadrature of exact_albedo over the (θ_h, φ_h) rule, per view: (F ≡ 1, F = (1 −
    o·h)⁵) sums (one pass per view over the rule, no (θ, φ, 3) temporaries)."""
    out = np.zeros((cos_o.shape[0], 2))
    a2 = alpha * alpha
    for k in range(cos_o.shape[0]):
        c = cos_o[k]
        ox, oz = np.sqrt(max(0.0, 1.0 - c * c)), c
        z2 = min(max(oz * oz, 1e-12), 1.0)
        lo = np.sqrt(1.0 + a2 * (1.0 - z2) / z2)
        s1 = 0.0
        s2 = 0.0
        for u in range(th.shape[0]):
            st, ct = np.sin(th[u]), np.cos(th[u])
            q = st * st / a2 + ct * ct
            d = 1.0 / (np.pi * a2 * q * q)
            for v in range(ph.shape[0]):
                hx = st * np.cos(ph[v])
                oh = hx * ox + ct * oz
                iz = 2.0 * oh * ct - oz
                if oh <= 0.0 or iz <= 1e-9:
                    continue
                zi = max(iz, 1e-6)
                zi2 = min(max(zi * zi, 1e-12), 1.0)
                li = np.sqrt(1.0 + a2 * (1.0 - zi2) / zi2)
                g2 = 2.0 / (lo + li) if kind == 8 else (2.0 / (1.0 + lo)) * (2.0 / (1.0 + li))
                f = wth[u] * wph[v] * st * d * g2 * oh / c
                s1 += f
                s2 += f * (1.0 - min(max(oh, 0.0), 1.0)) ** 5
        out[k, 0], out[k, 1] = s1, s2
    return out


def _furnace_material(m, alpha: float, lobes):
    """A copy of GGX material m at roughness α, no diffuse, the given lobes, Schlick with
    F0 = (1, 0, 0): its red channel is the F ≡ 1 response, green the (1 − o·h)⁵ one."""
    from dataclasses import replace
    return replace(m, name=f"{m.name}@{alpha:.4g}", kd=np.zeros(3), ks=np.ones(3), diffuse=2,
                   fresnel=1, f0=np.array([1.0, 0.0, 0.0]), alpha_u=alpha, alpha_v=alpha,
                   g_scale=1.0 / (4.0 * alpha * alpha),
                   lobe_axis=np.tile([0.0, 0.0, 1.0], (len(lobes[0]), 1)),
                   lobe_lambda=np.asarray(lobes[0], float), lobe_mu=np.asarray(lobes[1], float),
                   asg_z=np.zeros((0, 3)), asg_x=np.zeros((0, 3)), asg_lambda=np.zeros(0),
                   asg_mu=np.zeros(0), asg_amp=np.zeros(0), gmm=None, gmm_toral19=None,
                   ndf_table=None, kd_texture=-1, ks_texture=-1, gltf=None, rough_grid=None,
                   energy=None, energy_grid=None, exact_warp=True)


def _sg_furnace(mats: list) -> np.ndarray:
    """`sg`'s environment specular in a white furnace, (len(mats), ENERGY_VIEWS, 2) (F ≡ 1,
    F = (1 − o·h)⁵): per material one pixel per view, normal +z, view in the x-z plane, no
    shadows, no diffuse."""
    from sgpipe.render.envdata import EnvData
    from sgpipe.render.materials import pack_materials
    from sgpipe.render.records import KernelFlag
    from sgpipe.render.renderer import Frame, ObjectShading, Renderer
    r = Renderer(env=EnvData.constant(1.0), materials=pack_materials(mats),
                 objects=[ObjectShading(k) for k in range(len(mats))])
    c = view_cosines()
    nm, nv = len(mats), len(c)
    n = nm * nv
    f4 = lambda a: np.concatenate([a, np.zeros((n, 1))], 1).astype(np.float32)  # noqa: E731
    view = np.tile(np.stack([np.sqrt(1 - c * c), np.zeros(nv), c], -1), (nm, 1))
    fr = Frame(index=np.arange(n), shape=(n,), normal=f4(np.tile([0.0, 0.0, 1.0], (n, 1))),
               tangent=f4(np.tile([1.0, 0.0, 0.0], (n, 1))), view=f4(view),
               position=f4(np.zeros((n, 3))), uv=np.zeros((n, 2), np.float32),
               obj=np.repeat(np.arange(nm), nv).astype(np.int32),
               tri=np.full(n, -1, np.int32), bary=np.zeros((n, 2), np.float32))
    rgb = r.shade("sg", fr, flags=KernelFlag.NO_ENV_DIFFUSE | KernelFlag.NO_VISIBILITY)
    return rgb[:, :2].reshape(nm, nv, 2).astype(np.float64)


#: the table's domain: lobes at least this broad (a lobe near λ = 0 covers the sphere, where
#: sg's response jumps by ±15 % from one degree of view to the next)
MIN_LOBE_LAMBDA = 0.3


def _broad_enough(lam) -> bool:
    return len(lam) > 0 and float(np.min(lam)) >= MIN_LOBE_LAMBDA * 0.999


def qualifies(m) -> bool:
    """An isotropic GGX material with a specular lobe whose own lobes, or else its roughness
    grid's, stay at least MIN_LOBE_LAMBDA sharp (the table's domain)."""
    return (int(m.shadowing) in GGX_SHADOWING and m.alpha_u == m.alpha_v and m.alpha_u > 0
            and len(m.lobe_lambda) > 0 and np.any(np.asarray(m.ks) > 0)
            and len(m.asg_lambda) == 0
            and (_broad_enough(m.lobe_lambda)
                 or (m.rough_grid is not None and _broad_enough(m.rough_grid.sharpness))))


def adopt_grid_lobes(m) -> None:
    """A GGX material whose fitted lobes include one near λ = 0 takes its roughness grid's lobes
    at its α instead (a textured pixel's of that roughness; the grid's sharpness floor keeps
    sg's response smooth in the view). Every method reading the lobes sees the same ones."""
    g = m.rough_grid
    if (g is None or int(m.shadowing) not in GGX_SHADOWING or m.alpha_u != m.alpha_v
            or _broad_enough(m.lobe_lambda) or not _broad_enough(g.sharpness)
            or len(m.lobe_lambda) == 0 or len(m.asg_lambda) > 0):
        return
    lam, mu = rough_lobes_at(g.alpha, g.sharpness, g.amplitude, float(m.alpha_u))
    m.lobe_axis = np.tile([0.0, 0.0, 1.0], (len(lam), 1))
    m.lobe_lambda, m.lobe_mu = lam, mu


def attach_energy(materials: list) -> None:
    """Set `energy` (ENERGY_VIEWS, 4) and, with a roughness grid, `energy_grid` (ENERGY_VIEWS,
    R, 4) on every qualifying material: per view the exact albedos (a1: F ≡ 1, a2: F =
    (1 − o·h)⁵) and sg's furnace responses (s1, s2). sg's specular and the exact one are both
    linear in Schlick's F0, so the kernels scale by (F0 a1 + (1 − F0) a2) / (F0 s1 + (1 − F0)
    s2) per channel (a1 / s1 for another Fresnel)."""
    jobs = []            # (material, column or None, α, lobes)
    for m in materials:
        if not qualifies(m):
            continue
        adopt_grid_lobes(m)
        g = m.rough_grid
        if g is not None and not _broad_enough(g.sharpness):
            g = None
        jobs.append((m, None, float(m.alpha_u), (m.lobe_lambda, m.lobe_mu)))
        if g is not None and m.gltf is not None:
            for i, a in enumerate(np.asarray(g.alpha, float)):
                jobs.append((m, i, a, (g.sharpness[i], g.amplitude[i])))
    if not jobs:
        return
    # one furnace pixel set and quadrature per distinct (G2 kind, α, lobes): the roughness
    # grids of a file's glTF materials are the same grid
    keys = [(int(m.shadowing), a, np.asarray(lb, np.float64).tobytes()) for m, _, a, lb in jobs]
    unique = list(dict.fromkeys(keys))
    first = {k: keys.index(k) for k in unique}
    resp = dict(zip(unique, _sg_furnace([_furnace_material(jobs[first[k]][0], k[1],
                                                           jobs[first[k]][3])
                                         for k in unique])))
    c = view_cosines()
    rows_of = {k: np.concatenate([exact_albedo(k[1], c, k[0]), resp[k]], 1).astype(np.float32)
               for k in unique}
    for m, *_ in jobs:
        m.exact_warp = True
    for (m, col, a, _), k in zip(jobs, keys):
        rows = rows_of[k]
        if col is None:
            m.energy = rows
        else:
            if m.energy_grid is None:
                m.energy_grid = np.zeros((len(c), len(m.rough_grid.alpha), 4), np.float32)
            m.energy_grid[:, col] = rows
