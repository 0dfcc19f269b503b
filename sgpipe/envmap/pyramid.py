"""Γ_L pyramid (Wang09 eq 34–35): the environment convolved with normalized SG kernels.

Level ℓ stores V_ℓ(p) = Γ_L(p, λ_ℓ)/S(λ_ℓ) with Γ_L(p, λ) = ∫ e^{λ(ω·p−1)} L(ω) dω and
S(λ) = 2π(1 − e^{−2λ})/λ, plus the log-slope m_ℓ(p) = ∂ln Γ_L/∂ln λ used to interpolate in λ
(cubic Hermite of ln Γ_L in ln λ). Both are stored as uniform cubic B-spline coefficients on a
bordered cubemap (see docs/ARTIFACTS.md, `envmap/`).

Build: the cubemap texels become point masses (E = L·Ω at the texel centre), split in a "dim"
layer (bounded contrast: short kernel tails) and a sparse "bright" layer (sun, lamps: long
tails; kept as exact points beside the levels when small). Levels 0 and 1 are computed straight
from the masses, each level below them (λ ≥ `chain_lambda_min`) from the samples of a sharper
level (two above on every other texel, or one above on every texel when the levels are stored
at 1.5 texels per σ: the chain plan in `build_pyramid`) with the exact zonal difference kernel
(sgkernel.py) and a smooth quadrature across the cube edges (`_chain_source`). The storage
density follows the content (`auto_texels_per_sigma`). Sharp kernels are summed row by row (`_row_gather`, _rows_jit.py:
every cube-face row is a great circle, so a zonal kernel factorises into a sum along each row
and a sum over the rows in reach: ~10–30 row taps per output instead of ~100–800 texels);
broader ones, and a sun's bright layer at the direct levels, by the 2-D gather
(`_pyramid_jit.sg_gather`). The broad levels are direct gathers from a moment-preserving MIP of
the masses (energy, energy-weighted centroid and spread per merged texel) that still samples
their kernel finely enough.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numba
import numpy as np

from sgpipe.core.maps import cubemap_face_solid_angles
from sgpipe.envmap import _pyramid_jit as _pj
from sgpipe.envmap import _rows_jit as _rj
from sgpipe.envmap._cube_jit import FACE_UVA, sample_bordered
from sgpipe.envmap.maps import faces_to_image
from sgpipe.envmap.mip import bordered_box_level
from sgpipe.envmap.sgkernel import difference_kernel, sg_kernel

BORDER = 2          # stored border (cubic B-spline taps −1..+2 never leave the bordered face)
_EXTRA = 5          # extra computed border consumed by the B-spline prefilter (0.268^5 ≈ 1e-3)


def sg_norm(lam):
    """S(λ) = ∫_{S²} e^{λ(ω·p−1)} dω = 2π(1 − e^{−2λ})/λ (→ 4π as λ → 0)."""
    lam = np.asarray(lam, float)
    small = lam < 1e-8
    ls = np.where(small, 1.0, lam)
    return np.where(small, 4.0 * np.pi * (1.0 - lam), -2.0 * np.pi * np.expm1(-2.0 * ls) / ls)


def mean_resultant(lam):
    """A(λ) = coth λ − 1/λ (λ/3 for small λ): the l = 1 response of the normalized SG kernel."""
    lam = np.asarray(lam, float)
    small = lam < 1e-3
    ls = np.where(small, 1.0, lam)
    return np.where(small, lam / 3.0, 1.0 / np.tanh(ls) - 1.0 / ls)


@dataclass
class PyramidSettings:
    """Knobs of the pyramid build (the config section mirrors these)."""

    ratio: float = math.sqrt(2.0)        # λ_ℓ / λ_ℓ₊₁
    texels_per_sigma: float = 0.0        # output texel pitch at a face centre = σ / this;
                                         # 0 = from the content (`auto_texels_per_sigma`)
    finest_texels_per_sigma: float = 2.0  # λ_0: σ = this many finest texels (face centre)
    lambda_min: float = 0.25             # levels continue down to the first λ <= this
    min_res: int = 4                     # smallest face resolution of a level
    src_texels_per_sigma: float = 1.5    # dim layer: coarsest source MIP with σ/h >= this
    bright_src_texels_per_sigma: float = 1.7
    bright_factor: float = 16.0          # texels brighter than this × median go to the bright layer
    tail_dim: float = 4.5                # kernel cut at e^{−T²/2} for the dim layer
    tail_bright: float = 0.0             # 0 = from the bright layer's dynamic range (4.5 … 7)
    tile: int = 4
    max_points: int = 256                # a bright layer of at most this many texels is kept as
                                         # exact point masses instead of pyramid levels
    chain_lambda_min: float = 20.0       # levels with λ >= this (below level 0) are computed
                                         # from a sharper level with the exact difference
                                         # kernel (sgkernel.py) while its fit is within
    chain_max_fit_error: float = 5e-4    # this (ratio √2: 4e-4 at λ 22.6, 1e-3 at 16; smaller
                                         # ratios fit worse: 1.1 → 1e-3 at λ 64); the levels
                                         # after the chain stops come from the moment MIP
    chain_min_sampling: float = 0.7      # and the source level samples the step's
                                         # integrand at >= this many texels per its width
    tail_chain: float = 4.5              # difference kernel cut at this many of its σ
    direct_levels: int = 2               # the sharpest levels come straight from the map's
                                         # texels (1, level 1 chained from level 0 by rows:
                                         # as accurate on tests/envmap and the real sky_sun at
                                         # 512², build time within noise)
    bright_rows_max_contrast: float = 1e3  # a bright layer up to this × the median (lamps)
                                         # is summed by rows too at the direct levels; above
                                         # (a sun) the 2-D gather (real sky_sun 512², 9.7·10⁴:
                                         # level 0 0.47 % off instead of 0.68 %)
    rows_lambda_min: float = 500.0       # kernels with λ_d >= this are summed row by row
                                         # (_rows_jit: ~10–30 row taps per output instead of
                                         # ~100–800 texels; on 256² maps its levels down to
                                         # λ_d 362 are as close to brute force as the 2-D
                                         # gather's or closer)


AUTO_TEXELS_PER_SIGMA = (1.5, 2.0)      # (levels of bounded contrast, a sun in the levels)


def auto_texels_per_sigma(s: PyramidSettings, sun_in_levels: bool) -> float:
    """The levels' storage density: `texels_per_sigma` when set, else 2 texels per σ when a
    bright layer of more than `bright_rows_max_contrast` × the median stays in the levels (a
    sun too large for the point set: its tails next to dark sky need the denser B-spline; the
    real sky_sun at 512², 304 texels at 10⁵ ×, is 1.4 % off at 1.5 and 0.54 % at 2), else 1.5
    (levels of bounded contrast: the dim layer, lamps, a point-set sun; ≤ 0.13 % off on the
    benchmark's sky and ≤ 0.09 % on the real studio at 512², with 0.56× the texels)."""
    if s.texels_per_sigma > 0.0:
        return float(s.texels_per_sigma)
    return AUTO_TEXELS_PER_SIGMA[1] if sun_in_levels else AUTO_TEXELS_PER_SIGMA[0]


def pyramid_levels(n_finest: int, s: PyramidSettings,
                   k: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """λ_ℓ (decreasing, uniformly log-spaced) and face resolution per level.

    λ_0 is the sharpest kernel the finest texels sample at `finest_texels_per_sigma` = k_0 per
    σ (σ = 1/√λ, face-centre pitch 2/N): λ_0 = (N/(2k_0))²; each level is stored at k texels
    per σ (default `auto_texels_per_sigma` without a sun in the levels):
    n_ℓ = clamp(⌈2k√λ_ℓ⌉, min_res, N).
    """
    k = k or auto_texels_per_sigma(s, False)
    lam0 = (n_finest / (2.0 * s.finest_texels_per_sigma)) ** 2
    lams = [lam0]
    while lams[-1] > s.lambda_min:
        lams.append(lams[-1] / s.ratio)
    lams = np.array(lams)
    res = np.clip(np.ceil(2.0 * k * np.sqrt(lams) - 1e-9), s.min_res, n_finest).astype(np.int64)
    return lams, res


def _point_masses(cube: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """Finest source row blocks (6, N, NCOMP, N) float32 of a (6, N, N, 3) cubemap: texel
    centres, energies L·Ω (where `mask`, default everywhere), zero spread."""
    cube = np.ascontiguousarray(cube, dtype=np.float64)
    if mask is None:
        mask = np.ones(cube.shape[:3], bool)
    return _layer_masses(cube, cubemap_face_solid_angles(cube.shape[1]), mask, True)[0]


def _layer_masses(cube, omega, mask, keep):
    """`_pyramid_jit.layer_masses` into a numpy-allocated block."""
    n = cube.shape[1]
    return _pj.layer_masses(cube, omega, mask, keep, np.empty((6, n, _pj.NCOMP, n), np.float32))


class _MomentMip:
    """Moment MIP of one layer, built lazily from the finest level (levels kept once built)."""

    def __init__(self, src0: np.ndarray):
        self.n0 = src0.shape[1]
        self.levels = [src0]
        self.exts = [_pj.row_extents(src0)]

    def level(self, j: int):
        while len(self.levels) <= j:
            nxt = _pj.moment_downsample(self.levels[-1])
            self.levels.append(nxt)
            self.exts.append(_pj.row_extents(nxt))
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
        """(row blocks, row extents) of the coarsest MIP level sampling σ at >= k_src per σ.
        (Re-binning to the exact resolution was tried: the irregular bins cost accuracy.)"""
        return self.level(self.pick(sigma, k_src))

    def release_below(self, j: int) -> None:
        """Drop levels finer than j (built first, so coarser levels stay reachable)."""
        self.level(j)
        for i in range(j):
            self.levels[i] = None
            self.exts[i] = None


def _bright_mask(lum: np.ndarray, factor: float) -> tuple[np.ndarray, float, float]:
    """(texels above factor × the typical luminance, that threshold, the typical luminance:
    the median, at least 1e-3 × the mean) of a (6, N, N) luminance (channel sum)."""
    med = max(float(np.median(lum)), 1e-3 * float(lum.mean()), 1e-30)
    tau = factor * med
    return lum > tau, tau, med


@dataclass
class Pyramid:
    """A built or loaded Γ_L pyramid with the reference lookup of docs/ARTIFACTS.md."""

    lambdas: np.ndarray                  # (L,) decreasing
    face_res: np.ndarray                 # (L,)
    values: list[np.ndarray]             # per level (6·(n+4), n+4, 3) B-spline coeffs of V
    slopes: list[np.ndarray]             # per level (6·(n+4), n+4, 3) B-spline coeffs of m
    mean: np.ndarray                     # (3,) mean radiance (the λ → 0 limit)
    ratio: float
    info: dict = field(default_factory=dict)
    samples: list[np.ndarray] | None = None   # per level (6·(n+2), n+2, 3) V samples, border 1
    # sparse bright texels kept out of the levels: Γ_L += Σ_k E_k e^{λ(c_k·p − 1)} exactly
    point_dirs: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    point_energy: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    # the finest cubemap the levels were built from (points removed), "cube6v_b1": the λ → ∞
    # end of the sharp-side extrapolation (None: clamp to level 0)
    raw: np.ndarray | None = None

    def points_gamma(self, P: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """Σ_k E_k e^{λ(c_k·p − 1)} of the point set at unit P (M, 3), λ (M,) → (M, 3)."""
        out = np.zeros((len(P), 3))
        if len(self.point_dirs):
            for a in range(0, len(P), 4096):
                w = np.exp(lam[a:a + 4096, None] * (P[a:a + 4096] @ self.point_dirs.T - 1.0))
                out[a:a + 4096] = w @ self.point_energy
        return out

    @property
    def border(self) -> int:
        return BORDER

    def level_values(self, level: int, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(V_ℓ(p), m_ℓ(p)) at unit directions (M, 3) by cubic B-spline lookup."""
        d = np.ascontiguousarray(np.asarray(dirs, float).reshape(-1, 3))
        n = int(self.face_res[level])
        v = sample_bordered(self.values[level], n, BORDER, d, True, np.empty((len(d), 3)))
        m = sample_bordered(self.slopes[level], n, BORDER, d, True, np.empty((len(d), 3)))
        return v, m

    def lookup_simple(self, p, lam, *, normalized: bool = False) -> np.ndarray:
        """The cheap variant of docs/ARTIFACTS.md: bilinear V samples (border 1), linear in
        ln λ between levels (same clamps). Up to ~5–20 % off near bright sources between levels."""
        p = np.asarray(p, float)
        lam = np.asarray(lam, float)
        shape = np.broadcast_shapes(p.shape[:-1], lam.shape)
        P = np.ascontiguousarray(np.broadcast_to(p, shape + (3,)).reshape(-1, 3))
        lamv = np.broadcast_to(lam, shape).reshape(-1)
        L = len(self.lambdas)
        x = np.log(self.lambdas[0] / np.maximum(lamv, 1e-300)) / math.log(self.ratio)
        out = np.empty((len(P), 3))
        lo = np.clip(np.floor(x), 0, L - 1).astype(int)
        for l in np.unique(lo):
            sel = lo == l
            n = int(self.face_res[l])
            va = sample_bordered(self.samples[l], n, 1, P[sel], False, np.empty((sel.sum(), 3)))
            if l + 1 < L:
                nb = int(self.face_res[l + 1])
                vb = sample_bordered(self.samples[l + 1], nb, 1, P[sel], False,
                                     np.empty((sel.sum(), 3)))
                t = np.clip(x[sel] - l, 0.0, 1.0)[:, None]
                va = (1 - t) * va + t * vb
            else:
                w = (mean_resultant(lamv[sel]) / mean_resultant(self.lambdas[-1]))[:, None]
                va = np.where(x[sel, None] > L - 1, self.mean + w * (va - self.mean), va)
            out[sel] = va
        out += self.points_gamma(P, lamv) / sg_norm(lamv)[:, None]
        out = out.reshape(shape + (3,))
        return out if normalized else out * np.broadcast_to(sg_norm(lam), shape)[..., None]

    def lookup(self, p, lam, *, normalized: bool = False) -> np.ndarray:
        """⟨G(·; p, λ, 1), L⟩ = Γ_L(p, λ) (Wang09 eq 35) for unit p (..., 3) and λ (broadcast);
        normalized=True returns V = Γ_L/S(λ) (a weighted mean radiance). Returns (..., 3).
        Cubic B-spline in p, cubic Hermite of ln Γ_L in ln λ (the accurate path)."""
        p = np.asarray(p, float)
        lam = np.asarray(lam, float)
        shape = np.broadcast_shapes(p.shape[:-1], lam.shape)
        P = np.ascontiguousarray(np.broadcast_to(p, shape + (3,)).reshape(-1, 3))
        lamv = np.broadcast_to(lam, shape).reshape(-1)
        out = np.empty((len(P), 3))
        lam0 = self.lambdas[0]
        L = len(self.lambdas)
        lnr = math.log(self.ratio)
        x = np.log(lam0 / np.maximum(lamv, 1e-300)) / lnr
        sharp = x < 0
        broad = x > L - 1
        mid = ~(sharp | broad)
        if sharp.any():   # sharper than level 0: towards the unfiltered map
            out[sharp] = self._sharp(np.ascontiguousarray(P[sharp]), lamv[sharp])
        if broad.any():
            vl, _ = self.level_values(L - 1, P[broad])
            w = (mean_resultant(lamv[broad]) / mean_resultant(self.lambdas[-1]))[:, None]
            out[broad] = self.mean + w * (vl - self.mean)
        if mid.any():
            idx = np.nonzero(mid)[0]
            lev = np.minimum(np.floor(x[idx]).astype(int), L - 2)
            for l in np.unique(lev):
                sel = idx[lev == l]
                out[sel] = self._hermite(l, P[sel], lamv[sel], x[sel] - l)
        out += self.points_gamma(P, lamv) / sg_norm(lamv)[:, None]
        out = out.reshape(shape + (3,))
        if normalized:
            return out
        return out * np.broadcast_to(sg_norm(lam), shape)[..., None]

    def _hermite(self, l: int, P: np.ndarray, lam: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Cubic Hermite of y = ln Γ in u = ln λ between levels l and l+1 (t ∈ [0, 1])."""
        va, ma = self.level_values(l, P)
        vb, mb = self.level_values(l + 1, P)
        return hermite_ln(va, ma, self.lambdas[l], vb, mb, self.lambdas[l + 1], lam, t)

    def _sharp(self, P: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """λ > λ_0: the same Hermite of ln Γ in ln λ from level 0 (V_0, m_0) to the unfiltered
        map at λ_r = 1.5 N² (bilinear reconstruction blurs by h²/6, h = 2/N: λ_r = 6/h²; its
        slope is that of S alone), V = V_raw beyond; without `raw`, V = V_0 (clamped)."""
        v0, m0 = self.level_values(0, P)
        if self.raw is None:
            return v0
        n = self.raw.shape[1] - 2
        vr = sample_bordered(self.raw, n, 1, P, False, np.empty((len(P), 3)))
        lam0, lam_r = float(self.lambdas[0]), 1.5 * n * n
        if lam_r <= lam0:
            return v0
        t = np.clip(np.log(lam / lam0) / math.log(lam_r / lam0), 0.0, 1.0)
        mr = np.full_like(vr, float(dln_sg_norm(lam_r)))
        return hermite_ln(v0, m0, lam0, vr, mr, lam_r, np.minimum(lam, lam_r), t)


def dln_sg_norm(lam):
    """∂ln S/∂ln λ = 2λ/(e^{2λ} − 1) − 1: the log-slope of Γ_L of a constant map."""
    x = np.clip(2.0 * np.asarray(lam, float), 1e-300, 700.0)
    return np.where(x < 2e-8, -0.5 * x, x / np.expm1(x) - 1.0)


def hermite_ln(va, ma, la, vb, mb, lb, lam, t):
    """V at λ (t ∈ [0, 1] its position in ln λ between la and lb) from a cubic Hermite of
    y = ln Γ = ln(S·V) in u = ln λ with end slopes m (per channel); linear V where V ≤ 0."""
    t = np.asarray(t, float)[:, None]
    lin = (1.0 - t) * va + t * vb
    ok = (va > 0) & (vb > 0)
    ya = np.log(np.where(ok, va, 1.0) * sg_norm(la))
    yb = np.log(np.where(ok, vb, 1.0) * sg_norm(lb))
    du = math.log(lb / la)
    t2 = t * t
    t3 = t2 * t
    y = ((2 * t3 - 3 * t2 + 1) * ya + (t3 - 2 * t2 + t) * du * ma
         + (-2 * t3 + 3 * t2) * yb + (t3 - t2) * du * mb)
    herm = np.exp(y) / sg_norm(lam)[:, None]
    return np.where(ok, herm, lin)


_NO_KERN = np.zeros(0)


_CHAIN_PAD = 7      # chain source: texels kept beyond each face edge (a subsampled grid must
                    # still reach past the blend)
_CHAIN_BLEND = 5.0  # half-width of the faces' partition-of-unity blend, in texels


class _Pool:
    """Work buffers of one build, kept and reused from level to level (grown when a level needs
    more): fresh pages cost 2–3 µs per 4 KB to fault in, and the levels' accumulators, row sums,
    chain sources and lines add up to several hundred MB over a 512² build. A caller takes a
    slot only while the previous taker of the same slot is done with it."""

    def __init__(self):
        self.bufs = {}

    def take(self, key, shape, dtype=np.float32, zero=False) -> np.ndarray:
        shape = tuple(int(x) for x in shape)
        size = math.prod(shape)
        buf = self.bufs.get(key)
        if buf is None or buf.size < size or buf.dtype != dtype:
            buf = np.empty(size, dtype)
            self.bufs[key] = buf
        out = buf[:size].reshape(shape)
        if zero:
            out.fill(0)
        return out

    def drop(self, *names) -> None:
        """Release the slots named (a key, or the first element of a tuple key)."""
        for key in list(self.bufs):
            if key in names or (isinstance(key, tuple) and key[0] in names):
                del self.bufs[key]


def _map_grid(n: int) -> tuple[float, float]:
    """(h, c0) of a plain cubemap face grid: centres at c0 + i·h."""
    return 2.0 / n, -1.0 + 1.0 / n


def _chain_source(acc: np.ndarray, n: int, ext: int, norm: float, step: int,
                  out: np.ndarray | None = None):
    """A level's V = Γ/S on its grid extended _CHAIN_PAD texels beyond each face (from the
    gather's accumulator, border `ext`) as quadrature masses at the texel centres: the sources
    of the next chained level. The weights are the midpoint rule in each face's gnomonic
    coordinates (J·h², J = (1+s²+t²)^{−3/2}, h = 2/n) times the face's share of a smooth
    partition of unity across the edges, so φ_f·J is smooth and vanishes towards the extended
    grid's rim: no edge or corner error terms (texel solid angles at the centres as the
    chain's weights left 3e-4 per level near the corners, 4e-3 after eleven levels). `step` 2
    keeps every other texel (the blend must stay wide on that grid: at 3.5 texels the
    subsampled chain lost 7e-4 per level near the edges, at 5 it matches `step` 1)."""
    shape = _pj.chain_source_shape(n, _CHAIN_PAD, step)
    if out is None:
        src = np.zeros(shape, np.float32)
    else:                               # a zeroed buffer of that shape (`_Pool.take`)
        src = out
    _pj.chain_source(acc, n, ext, norm, _CHAIN_PAD, _CHAIN_BLEND, FACE_UVA, step, src)
    h = 2.0 / n
    return src, _pj.row_extents(src), step * h, -1.0 + (0.5 - _CHAIN_PAD) * h


T_LIM_MAX = 1.6     # rows only while the lines in reach stay within |t| ≤ this of a face's
                    # plane (broader kernels: the lines fan out, the blocks get short and the
                    # 2-D gather of the small level is as fast)


def _row_gather(src, grid, kern, n_out, ext, acc, lam_min, lines_cache=None,
                t_build=0.0, pool=None, slot="lines") -> bool:
    """Add Γ, ∂Γ/∂λ of the zonal kernel `kern` (the gather's layout) over the masses `src` (row
    blocks on the grid (h, c0): centres at c0 + i·h) to the bordered accumulator acc by the
    row-factorised passes (_rows_jit): each face's rows and columns as two pencils of great
    circles, with the neighbouring faces' masses on the lines of the same pencils. False
    (nothing added) for λ_d below `lam_min` or beyond T_LIM_MAX. `lines_cache` (a dict) keeps
    the lines of `src` for the next call with the same source (built out to t_build); `pool`
    (a `_Pool`) lends the buffers of the row sums and of the lines (pool slot `slot`: the map's
    cached lines and the chained levels' share one, used one after the other)."""
    lam_d, zcut = float(kern[0]), float(kern[1])
    if lam_d < lam_min:
        return False
    n_out = int(n_out)
    t_lim = _rj.reach_t(lam_d, zcut, n_out, ext)
    if t_lim > T_LIM_MAX:   # the lines would fan out far beyond the faces
        return False
    # the lines of a source already built for a level reaching at least as far are reused
    # (levels 0 and 1 share the map's); extra lines are out of reach in pass 2
    cached = lines_cache.get("lines") if lines_cache is not None else None
    if cached is not None and cached[0] is src and cached[1] >= t_lim:
        lines = cached[2]
    else:
        t_b = max(t_lim, t_build) if t_build <= T_LIM_MAX else t_lim
        lines = _rj.build_lines(src, FACE_UVA, t_b, 0.1,
                                None if pool is None
                                else lambda k, shape: pool.take((slot, k), shape))
        if lines_cache is not None:
            lines_cache["lines"] = (src, t_b, lines)
    key_off, order, t, m_off, m_ca, m_cb, m_s, m_e, own = lines
    foot = _rj.lines_foot(key_off, order, t, lam_d, zcut, n_out, int(ext))
    h_o = 2.0 / n_out
    # samples beyond the bordered outputs at each end of a row: the feet's offset, the B-spline
    # taps and a run-in for the prefilter's mirror boundary (0.268¹⁰ ≈ 2e-6)
    margin = int(math.ceil(foot / h_o)) + 14
    m1 = n_out + 2 * (ext + margin) + 6
    x0 = -1.0 + (0.5 - ext - margin) * h_o
    kappa = 2.0 * kern[3] - kern[2] / lam_d
    k6 = np.ascontiguousarray(kern[:6], dtype=np.float64)
    ecoef = _rj.exponent_poly(kern)
    # one frame at a time: its lines' row sums (≤ ~5 MB at 512²) stay in the cache for pass 2
    # and the buffer is small
    for key in range(12):
        a, b = int(key_off[key]), int(key_off[key + 1])
        if a == b:
            continue
        need = (b - a) * _rj.NARR * m1
        buf = pool.take("C", (need,)) if pool is not None else np.empty(need, np.float32)
        C = _rj.row_pass1(t[a:b], m_off[a:b + 1], m_ca, m_cb, m_s, m_e, k6, n_out, x0, m1, src,
                          own[a:b], float(grid[1]), float(grid[0]), buf)
        _rj.row_pass2(C, key_off, order, t, k6, ecoef, float(kappa), float(kern[6]),
                      float(kern[7]), n_out, int(ext), x0, acc, key, key + 1)
    return True


def build_pyramid(cube: np.ndarray, settings: PyramidSettings | None = None) -> Pyramid:
    """Γ_L pyramid of a (6, N, N, 3) cubemap (OpenGL faces; rows ↔ t, columns ↔ s)."""
    s = settings or PyramidSettings()
    cube = np.ascontiguousarray(cube, dtype=np.float64)
    n_fin = cube.shape[1]
    t0 = time.perf_counter()
    lum = cube[..., 0] + cube[..., 1] + cube[..., 2]
    bright, tau, med = _bright_mask(lum, s.bright_factor)
    omega = cubemap_face_solid_angles(n_fin)
    src0, row_energy = _layer_masses(cube, omega, bright, False)
    dim = _MomentMip(src0)
    n_bright = int(bright.sum())
    as_points = 0 < n_bright <= s.max_points
    point_dirs, point_energy = np.zeros((0, 3)), np.zeros((0, 3))
    if as_points:       # a sun / a few lamps: exact at every λ, no λ interpolation error
        fb, ib, jb = np.nonzero(bright)
        point_dirs = _pj.texel_dirs_at(fb, ib, jb, n_fin)
        point_energy = cube[fb, ib, jb] * omega[ib, jb][:, None]
    brt = None
    if n_bright and not as_points:
        src0, row_bright = _layer_masses(cube, omega, bright, True)
        brt = _MomentMip(src0)
        row_energy += row_bright
    del src0
    contrast = float(lum.max()) / med
    bright_rows = contrast <= s.bright_rows_max_contrast
    k_store = auto_texels_per_sigma(s, brt is not None and not bright_rows)
    lams, res = pyramid_levels(n_fin, s, k_store)
    t_bright = s.tail_bright or float(np.clip(
        math.sqrt(2.0 * math.log(max(contrast, 1.0) * 1e3)), 4.5, 7.0))
    # a chained level cuts its kernel at t_chain of the difference kernel's σ: bright texels
    # kept in the levels need the longer tail of their dynamic range (a 5·10⁴ disk sun at 4.5:
    # 1.6 % off near it, at 6: 0.5 %)
    t_chain = max(s.tail_chain, t_bright) if brt is not None else s.tail_chain
    # the chain plan: level b ≥ n_direct comes from a sharper level a while λ, a's sampling and
    # the kernel fit allow. The quadrature of V_a·Δ on a's grid (pitch h at a face centre) is off by
    # ~e^{−2π²(σ_e/h)²}, σ_e² = (1 − λ_b/λ_a)/λ_a the integrand's width. Preferred: a = b − 2
    # (λ ratio 2) on every other texel of a (σ_e/h = 0.71 at 2 texels per σ: ~5e-5 per level,
    # 0.6× the taps of a = b − 1 on all its texels, σ_e/h = 1.08); ratio 1.1 would give 0.6
    # (8e-4 per level, 2 % after 25 levels) and is refused.
    plan = {}                   # b -> (a, step, (kern, amp, fit error))
    n_direct = max(1, min(s.direct_levels, len(lams)))
    for b in range(n_direct, len(lams)):
        if lams[b] < s.chain_lambda_min * (1 - 1e-9):
            break
        for a, step in ((b - 2, 2), (b - 1, 1)):
            if a < 0 or (a >= n_direct and a not in plan):
                continue
            sigma_e = math.sqrt((1.0 - lams[b] / lams[a]) / lams[a])
            if sigma_e * res[a] / (2.0 * step) < s.chain_min_sampling:
                continue
            kern = difference_kernel(float(lams[a]), float(lams[b]), t_chain)
            if kern[2] <= s.chain_max_fit_error:
                plan[b] = (a, step, kern)
                break
        if b not in plan:
            break
    values, slopes, samples = [], [], []
    row_levels = 0          # levels whose sharp kernel was summed row by row
    ext = BORDER + _EXTRA
    map_lines = {}          # the map's lines for the direct levels (built for the broadest)
    t_direct = max(_rj.reach_t(float(lams[i]), 0.5 * s.tail_dim ** 2, int(res[i]), ext)
                   for i in range(n_direct))
    sources = {}            # (a, step) -> level a as quadrature masses (`_chain_source`)
    # work buffers kept and reused by every level (`_Pool`)
    m0 = int(res[0]) + 2 * ext
    pool = _Pool()
    # chain sources: a source is consumed (popped) by level a + 1 or a + 2 before level a + 2
    # makes the next one of the same parity; with steps from b − 1 only, one slot is enough
    two_slots = any(b - a == 2 for b, (a, _, _) in plan.items())

    def source_key(level, step):
        return ("source", level % 2 if two_slots else 0, step)

    scratch = pool.take("prefilter", (numba.get_num_threads(), 3 * m0 * m0), np.float64)
    # every level's images carved from one block (one huge-page advised allocation faults in
    # a few hundred pages instead of ~10⁴)
    shapes = []
    for n in res:
        w = int(n) + 2 * BORDER
        shapes.append(((6 * w, w, 3), (6 * w, w, 3), (6 * (n + 2), n + 2, 3)))
    block = np.empty(sum(math.prod(sh) for lv in shapes for sh in lv), np.float32)
    out_views, pos = [], 0
    for lv in shapes:
        views = []
        for sh in lv:
            views.append(block[pos:pos + math.prod(sh)].reshape(sh))
            pos += math.prod(sh)
        out_views.append(tuple(views))
    del block
    for idx, (lam, n) in enumerate(zip(lams, res)):
        sigma = 1.0 / math.sqrt(lam)
        acc = pool.take("acc", (6, n + 2 * ext, n + 2 * ext, 6), zero=True)
        by_rows = False
        if idx < n_direct:  # the sharpest levels: straight from the map's texels
            for mip, tail in ((dim, s.tail_dim), (brt, t_bright)):
                if mip is not None:
                    src, ex = mip.level(0)
                    kern = sg_kernel(float(lam), tail)
                    cos_cut = max(-2.0, 1.0 - tail * tail / (2.0 * lam))
                    grid = _map_grid(src.shape[1])
                    # a bright layer of high contrast (a sun) stays with the 2-D gather: the
                    # rows' B-spline of the row sums is ~1e-3 off in the tails of a 10⁵ × sun
                    if (mip is dim or bright_rows) and _row_gather(
                            src, grid, kern, n, ext, acc, s.rows_lambda_min,
                            map_lines if mip is dim else None, t_direct, pool,
                            "lines" if mip is dim else "bright lines"):
                        by_rows = True
                    else:
                        _pj.sg_gather(src, ex, FACE_UVA, int(n), ext, float(lam), cos_cut,
                                      s.tile, acc, kern, *grid)
        elif idx in plan:   # from a sharper level (exact difference kernel)
            a, step, (kern, amp, _) = plan[idx]
            src, ex, h_src, c0 = sources.pop((a, step))
            cos_cut = max(-2.0, 1.0 - kern[1] / kern[0])
            by_rows = _row_gather(src, (h_src, c0), kern, n, ext, acc, s.rows_lambda_min,
                                  pool=pool)
            if not by_rows:
                pool.drop("lines", "C")     # (broader chain steps are not summed by rows)
                _pj.sg_gather(src, ex, FACE_UVA, int(n), ext, float(lam), cos_cut, s.tile, acc,
                              kern, h_src, c0)
            acc *= amp
        else:               # broad levels: from the moment MIP of the map
            pool.drop("lines", "C", "source")
            for mip, k_src, tail in ((dim, s.src_texels_per_sigma, s.tail_dim),
                                     (brt, s.bright_src_texels_per_sigma, t_bright)):
                if mip is None:
                    continue
                src, ex = mip.source(sigma, k_src)
                cos_cut = max(-2.0, 1.0 - tail * tail / (2.0 * lam))
                # small levels: wider tiles (fewer, longer passes over the broad kernel's
                # source rows; 4 → 8: these levels' 2-D gathers take ~⅓ less time)
                tile = s.tile if n > 32 else 2 * s.tile
                _pj.sg_gather(src, ex, FACE_UVA, int(n), ext, float(lam), cos_cut, tile, acc,
                              _NO_KERN, *_map_grid(src.shape[1]))
        vals, slps, smp = out_views[idx]
        row_levels += by_rows
        if idx == n_direct - 1:
            map_lines.clear()           # (the chained levels reuse their pool slot)
            pool.drop("bright lines")   # (only the direct levels sum a bright layer by rows)
        _pj.finish_level(acc, float(lam), float(sg_norm(lam)), _EXTRA, vals, slps, smp, scratch)
        values.append(vals)
        slopes.append(slps)
        samples.append(smp)
        for a, step, _ in plan.values():
            if a == idx:
                out = pool.take(source_key(idx, step),
                                _pj.chain_source_shape(int(n), _CHAIN_PAD, step), zero=True)
                sources[(a, step)] = _chain_source(acc, int(n), ext, float(sg_norm(lam)), step,
                                                   out)
        # keep memory bounded: drop source MIP levels finer than the next level taken from the
        # map needs (chained levels need none)
        later = [j for j in range(idx + 1, len(lams)) if j not in plan]
        if later:
            nxt = 1.0 / math.sqrt(float(lams[later[0]]))
            dim.release_below(dim.pick(nxt, s.src_texels_per_sigma))
            if brt is not None:
                brt.release_below(brt.pick(nxt, s.bright_src_texels_per_sigma))
    # mean of what the levels hold (the map minus the point set): their λ → 0 limit
    mean = row_energy.sum(axis=(0, 1)) / (4.0 * np.pi)
    info = {"tau_bright": tau, "bright_texels": n_bright, "tail_bright": t_bright,
            "direct_levels": n_direct, "chained_levels": len(plan),   # levels n_direct …
            "row_levels": row_levels,
            "chain_fit_error": max((p[2][2] for p in plan.values()), default=0.0),
            "tail_dim": s.tail_dim, "points": len(point_dirs), "texels_per_sigma": k_store,
            "build_s": time.perf_counter() - t0}
    raw = bordered_box_level(cube, np.float32, bright if as_points else None)
    return Pyramid(lambdas=lams, face_res=res, values=values, slopes=slopes, mean=mean,
                   ratio=s.ratio, info=info, samples=samples, point_dirs=point_dirs,
                   point_energy=point_energy, raw=raw)
