"""The exported specular cubemap: mip m holds the environment prefiltered with the split-sum
GGX lobe of roughness m/(M − 1) (sgpipe.export.ggx_mapping), from the Γ_L pyramid (Wang09
eq 35) through the SG-mixture mapping where that mixture is ≤ 1 % off, else by direct
quadrature of the source map (the broad lobes: small levels, cheap)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from sgpipe.artifacts.envmap import SAMPLE_BORDER, PyramidArtifacts
from sgpipe.core.maps import cubemap_solid_angles, cubemap_texel_dirs, dir_to_cubemap
from sgpipe.core.maps import cube_mip_chain
from sgpipe.envmap.pyramid import Pyramid
from sgpipe.export import ggx_mapping as gm

DIRECT_SOURCE_RES = 32      # source face res the direct quadrature sums over (≤ 0.2 % for α ≥ 0.3)


@dataclass
class SpecularLevel:
    """One exported mip: faces (6, n, n, 3) float64 and how they were made."""

    faces: np.ndarray
    roughness: float
    alpha: float
    method: str                     # "source" | "pyramid" | "direct"
    mixture: gm.SGMixture | None = None
    info: dict = field(default_factory=dict)

    def describe(self) -> dict:
        d = {"face_size": int(self.faces.shape[1]), "roughness": self.roughness,
             "alpha": self.alpha, "method": self.method}
        if self.mixture is not None:
            d.update(sg_weights=list(self.mixture.weights), sg_lambdas=list(self.mixture.lambdas),
                     sg_fit_rel_l2=self.mixture.rel_l2)
        return d


def source_cube(a: PyramidArtifacts, with_points: bool = True) -> np.ndarray:
    """The map the pyramid was built from, (6, N, N, 3): `pyramid/raw.exr` without its border
    plus (with_points) the point set put back into its texels (E/Ω: they are texel centres)."""
    if a.raw is None:
        raise ValueError("the pyramid has no raw.exr")
    b = SAMPLE_BORDER
    m = a.raw.shape[1]
    n = m - 2 * b
    faces = a.raw.reshape(6, m, m, 3)[:, b:b + n, b:b + n].astype(np.float64)
    if with_points and len(a.point_dirs):
        f, s, t = dir_to_cubemap(a.point_dirs)
        j = np.clip(np.floor(s * n).astype(int), 0, n - 1)
        i = np.clip(np.floor(t * n).astype(int), 0, n - 1)
        om = cubemap_solid_angles(n)[f, i, j]
        np.add.at(faces, (f, i, j), a.point_energy / om[:, None])
    return faces


def box_down(faces: np.ndarray, size: int) -> np.ndarray:
    """The solid-angle-weighted box MIP of `faces` at face size `size` (N/size a power of 2)."""
    for lv in cube_mip_chain(faces):
        if lv.shape[1] == size:
            return lv
    raise ValueError(f"face size {size} is not N/2^k of N = {faces.shape[1]}")


def ggx_direct(faces: np.ndarray, dirs: np.ndarray, alpha: float) -> np.ndarray:
    """Σ L Ω K_α(r·ω) / Σ Ω K_α(r·ω) over the texels of `faces` at unit r (M, 3) → (M, 3):
    the split-sum GGX prefilter by brute-force quadrature (α > 0)."""
    n = faces.shape[1]
    chunk = max(1, (1 << 21) // (6 * n * n))     # ~16 MB per (chunk × texels) temporary
    w = cubemap_solid_angles(n).reshape(-1)
    d = cubemap_texel_dirs(n).reshape(-1, 3)
    rad = faces.reshape(-1, 3)
    r = np.asarray(dirs, float).reshape(-1, 3)
    out = np.empty((len(r), 3))
    for a in range(0, len(r), chunk):
        k = gm.ggx_lobe(r[a:a + chunk] @ d.T, alpha) * w
        out[a:a + chunk] = (k @ rad) / k.sum(1, keepdims=True)
    return out


def points_ggx(point_dirs: np.ndarray, point_energy: np.ndarray, dirs: np.ndarray,
               alpha: float) -> np.ndarray:
    """Σ_k E_k K_α(r·c_k) / ∫K_α: the point set (a sun) through the exact GGX lobe."""
    r = np.asarray(dirs, float).reshape(-1, 3)
    if not len(point_dirs):
        return np.zeros((len(r), 3))
    return gm.ggx_lobe(r @ point_dirs.T, alpha) @ point_energy / gm.ggx_lobe_integral(alpha)


def pyramid_mixture(pyr: Pyramid, dirs: np.ndarray, mix: gm.SGMixture) -> np.ndarray:
    """Σ_j w_j V(r, λ_j) of the pyramid's levels (the SG-averaged radiance mixed with the GGX
    fit's weights) plus the point set (a sun) through the exact GGX lobe: the mixture's tails
    are Gaussian where GGX's fall as θ⁻⁴ and cross the horizon, which a source 10⁵ × brighter
    than the sky turns into 30 % errors far from it (measured on sky_sun)."""
    r = np.asarray(dirs, float).reshape(-1, 3)
    levels_only = replace(pyr, point_dirs=np.zeros((0, 3)), point_energy=np.zeros((0, 3)))
    out = np.zeros((len(r), 3))
    for w, lam in zip(mix.weights, mix.lambdas):
        if w > 0.0:
            out += w * levels_only.lookup(r, np.full(len(r), lam), normalized=True)
    return out + points_ggx(pyr.point_dirs, pyr.point_energy, r, mix.alpha)


def level_count(size: int) -> int:
    """A full mip chain of face size `size`: floor(log2 size) + 1 levels (down to 1 texel)."""
    return int(math.floor(math.log2(size))) + 1


def specular_levels(a: PyramidArtifacts, pyr: Pyramid, size: int, progress=None,
                    min_size: int = 1) -> list[SpecularLevel]:
    """The mips of the exported cubemap, face size `size` down to `min_size` (1: the full
    chain), roughness m/(count − 1); `progress(m, count, level)` after each. Level 0
    (roughness 0) is the source map itself (box-filtered when `size` < N)."""
    src = source_cube(a)
    # the broad levels: quadrature over a coarse box level of the map without its point set,
    # plus the points exactly (box-filtering a sun 10⁵ × the sky into a 32² texel moves it by
    # up to half a texel: 3.6 % at α 0.44 on sky_sun, measured)
    dim = source_cube(a, with_points=False)
    direct_src = box_down(dim, _direct_res(dim.shape[1]))
    levels = []
    count = level_count(size) - level_count(min_size) + 1
    for m in range(count):
        n = max(size >> m, 1)
        rough = gm.roughness_of_level(m, count)
        alpha = gm.alpha_of_roughness(rough)
        if m == 0 or alpha == 0.0:
            lv = SpecularLevel(box_down(src, n), rough, alpha, "source")
        else:
            dirs = cubemap_texel_dirs(n).reshape(-1, 3)
            mix = gm.fit_sg_mixture(alpha)
            if mix.rel_l2 <= gm.MAX_MIXTURE_REL_L2:
                vals = pyramid_mixture(pyr, dirs, mix)
                lv = SpecularLevel(vals.reshape(6, n, n, 3), rough, alpha, "pyramid", mix)
            else:
                vals = ggx_direct(direct_src, dirs, alpha) + points_ggx(
                    a.point_dirs, a.point_energy, dirs, alpha)
                lv = SpecularLevel(vals.reshape(6, n, n, 3), rough, alpha, "direct",
                                   info={"source_face_size": int(direct_src.shape[1])})
        levels.append(lv)
        if progress is not None:
            progress(m, count, lv)
    return levels


def _direct_res(n: int) -> int:
    """The box level of an N-face map the direct quadrature uses: ≤ DIRECT_SOURCE_RES."""
    while n > DIRECT_SOURCE_RES and n % 2 == 0:
        n //= 2
    return n
