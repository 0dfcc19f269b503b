"""The map's texels as point masses E = L·Ω at their centres (the sum Γ_L of Wang09 eq 34 over
texels), split into a dim layer of bounded contrast (short kernel tails) and a sparse bright
layer (sun, lamps: long tails), kept as exact points beside the levels when it is small."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sgpipe.core.maps import cubemap_face_solid_angles
from sgpipe.envmap.pyramid import _masses_jit as _mj
from sgpipe.envmap.pyramid.settings import PyramidSettings


def layer_masses(cube, omega, mask, keep):
    """`_masses_jit.layer_masses` into a numpy-allocated block."""
    n = cube.shape[1]
    return _mj.layer_masses(cube, omega, mask, keep, np.empty((6, n, _mj.NCOMP, n), np.float32))


def point_masses(cube: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """Finest source row blocks (6, N, NCOMP, N) float32 of a (6, N, N, 3) cubemap: texel
    centres, energies L·Ω (where `mask`, default everywhere), zero spread."""
    cube = np.ascontiguousarray(cube, dtype=np.float64)
    if mask is None:
        mask = np.ones(cube.shape[:3], bool)
    return layer_masses(cube, cubemap_face_solid_angles(cube.shape[1]), mask, True)[0]


def bright_mask(lum: np.ndarray, factor: float) -> tuple[np.ndarray, float, float]:
    """(texels above factor × the typical luminance, that threshold, the typical luminance:
    the median, at least 1e-3 × the mean) of a (6, N, N) luminance (channel sum)."""
    med = max(float(np.median(lum)), 1e-3 * float(lum.mean()), 1e-30)
    tau = factor * med
    return lum > tau, tau, med


class MomentMip:
    """Moment MIP of one layer, built lazily from the finest level (levels kept once built)."""

    def __init__(self, src0: np.ndarray):
        self.n0 = src0.shape[1]
        self.levels = [src0]
        self.exts = [_mj.row_extents(src0)]

    def level(self, j: int):
        while len(self.levels) <= j:
            nxt = _mj.moment_downsample(self.levels[-1])
            self.levels.append(nxt)
            self.exts.append(_mj.row_extents(nxt))
        return self.levels[j], self.exts[j]

    def pick(self, sigma: float, k_src: float, min_res: int = 8) -> int:
        """Coarsest power-of-two level whose resolution is at least `target_res`."""
        n_t = self.target_res(sigma, k_src, min_res)
        n = self.n0
        j = 0
        while n % 2 == 0 and n // 2 >= n_t:
            n //= 2
            j += 1
        return j

    def target_res(self, sigma: float, k_src: float, min_res: int = 8) -> int:
        """Face resolution whose centre pitch 2/n samples σ at k_src per σ (capped at N)."""
        return int(min(self.n0, max(min_res, math.ceil(2.0 * k_src / sigma - 1e-9))))

    def source(self, sigma: float, k_src: float):
        """(row blocks, row extents) of the coarsest MIP level sampling σ at >= k_src per σ
        (power-of-two levels: re-binning to the exact resolution makes irregular bins, which
        cost accuracy)."""
        return self.level(self.pick(sigma, k_src))

    def release_below(self, j: int) -> None:
        """Drop levels finer than j (built first, so coarser levels stay reachable)."""
        self.level(j)
        for i in range(j):
            self.levels[i] = None
            self.exts[i] = None


@dataclass
class Layers:
    """The map split for the build: its masses by layer and what stays out of the levels."""

    dim: MomentMip                       # texels up to tau
    bright: MomentMip | None             # texels above tau kept in the levels (None: none,
                                         # or all in the point set)
    bright_texels: np.ndarray            # (6, N, N) bool: the texels above tau
    as_points: bool                      # the bright texels are the point set
    point_dirs: np.ndarray               # (k, 3) the point set's texel centres
    point_energy: np.ndarray             # (k, 3) its energies L·Ω
    row_energy: np.ndarray               # (6, N, 3) energy per row of what the levels hold
    tau: float                           # the bright threshold
    contrast: float                      # the map's peak over its typical luminance
    tail_bright: float                   # kernel cut (in σ) for the bright layer
    bright_rows: bool                    # the bright layer is summed by rows at the direct
                                         # levels (lamps; a sun: the 2-D gather)

    @property
    def n_bright(self) -> int:
        return int(self.bright_texels.sum())

    @property
    def sun_in_levels(self) -> bool:
        """A bright layer of a sun's contrast stays in the levels (`auto_texels_per_sigma`)."""
        return self.bright is not None and not self.bright_rows

    def release_finer_than(self, sigma: float, s: PyramidSettings) -> None:
        """Keep memory bounded: drop the MIP levels finer than a level of kernel σ gathered
        from the map needs."""
        self.dim.release_below(self.dim.pick(sigma, s.src_texels_per_sigma))
        if self.bright is not None:
            self.bright.release_below(self.bright.pick(sigma, s.bright_src_texels_per_sigma))


def clustered_points(dirs: np.ndarray, energy: np.ndarray, f, i, j, max_points: int):
    """The bright texels merged over 2^k × 2^k blocks of their face, k the smallest with at most
    `max_points` non-empty blocks: per block one point at the energy-weighted mean direction
    (normalised) carrying the block's summed energy (power exact, first moment kept)."""
    w = energy.sum(axis=1)
    k = 0
    while True:
        k += 1
        key = (np.asarray(f, np.int64) << 40) | ((np.asarray(i, np.int64) >> k) << 20) \
            | (np.asarray(j, np.int64) >> k)
        blocks, inv = np.unique(key, return_inverse=True)
        if len(blocks) <= max_points:
            break
    d = np.zeros((len(blocks), 3))
    e = np.zeros((len(blocks), 3))
    np.add.at(d, inv, w[:, None] * dirs)
    np.add.at(e, inv, energy)
    return d / np.linalg.norm(d, axis=1, keepdims=True), e


def split_layers(cube: np.ndarray, s: PyramidSettings) -> Layers:
    """The (6, N, N, 3) float64 cubemap's texels as the dim and bright layers' masses."""
    n_fin = cube.shape[1]
    lum = cube[..., 0] + cube[..., 1] + cube[..., 2]
    bright, tau, med = bright_mask(lum, s.bright_factor)
    omega = cubemap_face_solid_angles(n_fin)
    src0, row_energy = layer_masses(cube, omega, bright, False)
    dim = MomentMip(src0)
    n_bright = int(bright.sum())
    as_points = 0 < n_bright <= s.max_points or (n_bright > 0 and s.bright_clusters
                                                  and s.max_points > 0)
    point_dirs, point_energy = np.zeros((0, 3)), np.zeros((0, 3))
    if as_points:       # a sun / a few lamps: exact at every λ, no λ interpolation error
        fb, ib, jb = np.nonzero(bright)
        point_dirs = _mj.texel_dirs_at(fb, ib, jb, n_fin)
        point_energy = cube[fb, ib, jb] * omega[ib, jb][:, None]
        if n_bright > s.max_points:     # large lamps: blocks of texels as points
            point_dirs, point_energy = clustered_points(point_dirs, point_energy, fb, ib, jb,
                                                        s.max_points)
    brt = None
    if n_bright and not as_points:
        src0, row_bright = layer_masses(cube, omega, bright, True)
        brt = MomentMip(src0)
        row_energy += row_bright
    contrast = float(lum.max()) / med
    t_bright = s.tail_bright or float(np.clip(
        math.sqrt(2.0 * math.log(max(contrast, 1.0) * 1e3)), 4.5, 7.0))
    return Layers(dim=dim, bright=brt, bright_texels=bright, as_points=as_points,
                  point_dirs=point_dirs, point_energy=point_energy, row_energy=row_energy,
                  tau=tau, contrast=contrast, tail_bright=t_bright,
                  bright_rows=contrast <= s.bright_rows_max_contrast)
