"""Environment artifacts (`<out>/envmap/`, docs/ARTIFACTS.md envmap/) → packed arrays the
OpenCL kernels read: the normalised Γ_L pyramid (Wang09 eq 34–35), the box MIP chain (Töral19
eq 6–11, FIS) and the diffuse SG light fit (Wang09 §6). Read through the contract's readers
(sgpipe.artifacts.envmap), not via sgpipe.envmap.

Packed cubemap chain (`CubeChain`): float32 (T, 4) texels (RGB + 0), levels in order, each level
in the bordered "cube6v_b1" layout (6·(n+2) rows × (n+2) columns); `offsets[l]` is level l's
first texel, `res[l]` its face resolution n.

Rotation (render.environment_rotation): `EnvData.rotation` R (world ← map) turns the whole
environment: the kernels read the cubemaps at Rᵀd (cubemap.h `env_to_map`, compile-time defines
from `rotation_defines`), and the direction arrays beside them (point set, SG light axes) are
handed to the kernels already turned (`point_records`, `light_records`).

Packed accurate Γ_L chain (`GammaChain`, what `sg` reads): per level the "cube6v_b2" cubic
B-spline coefficients of V (`coef_LL`) and of m = ∂ln Γ_L/∂ln λ (`slope_LL`), interleaved per
texel as two float4 (V, 0), (m, 0): texel k of the chain is float4 2k (V) and 2k + 1 (m).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from sgpipe.artifacts import envmap as contract
from sgpipe.artifacts.envmap import COEF_BORDER, SAMPLE_BORDER
from sgpipe.core.rotation import checked_rotation
from sgpipe.core.sg import dln_sg_norm
from sgpipe.errors import BadInput


def bordered_dirs(n: int, border: int) -> np.ndarray:
    """Unit directions (6·(n+2B), n+2B, 3) of every texel of a "cube6v_bB" level."""
    from sgpipe.core.maps import cubemap_dir
    c = (np.arange(n + 2 * border) - border + 0.5) / n
    f = np.arange(6)[:, None, None]
    d = cubemap_dir(f, c[None, None, :], c[None, :, None])
    return d.reshape(6 * (n + 2 * border), n + 2 * border, 3)


def bilinear_b1(img: np.ndarray, n: int, d: np.ndarray) -> np.ndarray:
    """Bilinear lookup of a "cube6v_b1" level (6·(n+2), n+2, C) at directions (..., 3): the
    contract's fetch (docs/ARTIFACTS.md envmap/), clamped inside the direction's bordered face."""
    from sgpipe.core.maps import dir_to_cubemap
    face, s, t = dir_to_cubemap(np.asarray(d, float))
    w = n + 2
    im = np.asarray(img, np.float64).reshape(6, w, w, -1)
    u = np.clip(s * n + 0.5, 0.5, n + 0.5)
    v = np.clip(t * n + 0.5, 0.5, n + 0.5)
    j0 = np.minimum(np.floor(u).astype(int), n)
    i0 = np.minimum(np.floor(v).astype(int), n)
    fx, fy = (u - j0)[..., None], (v - i0)[..., None]
    return ((1 - fx) * (1 - fy) * im[face, i0, j0] + fx * (1 - fy) * im[face, i0, j0 + 1]
            + (1 - fx) * fy * im[face, i0 + 1, j0] + fx * fy * im[face, i0 + 1, j0 + 1])


def bspline_prefilter(img: np.ndarray, n: int, border: int) -> np.ndarray:
    """Per-face cubic B-spline coefficients (mirror boundary) interpolating the samples of a
    bordered level at every texel centre: (6·(n+2B), n+2B, C) → same shape."""
    from scipy.ndimage import spline_filter1d
    w = n + 2 * border
    f = np.asarray(img, np.float64).reshape(6, w, w, -1)
    for ax in (1, 2):
        f = spline_filter1d(f, order=3, axis=ax, mode="mirror")
    return f.reshape(6 * w, w, -1)


@dataclass
class CubeChain:
    """Levels of bordered cubemaps packed in one float4 buffer."""

    texels: np.ndarray   # (T, 4) float32
    offsets: np.ndarray  # (L,) int32
    res: np.ndarray      # (L,) int32 face resolution (without border)

    @classmethod
    def from_levels(cls, levels: list[np.ndarray]) -> "CubeChain":
        """From bordered level images, each (6·(n+2), n+2, 3)."""
        res, offs, parts, off = [], [], [], 0
        for img in levels:
            img = np.asarray(img, np.float32)
            w = img.shape[1]
            if img.ndim != 3 or img.shape[0] != 6 * w or w < 3:
                raise ValueError(f"not a bordered cubemap level: shape {img.shape}")
            rgba = np.zeros((img.shape[0] * w, 4), np.float32)
            rgba[:, :3] = img[..., :3].reshape(-1, 3)
            parts.append(rgba)
            offs.append(off)
            res.append(w - 2)
            off += len(rgba)
        return cls(np.concatenate(parts), np.asarray(offs, np.int32), np.asarray(res, np.int32))

    def level(self, l: int) -> np.ndarray:
        """Level l as its bordered image (6·(n+2), n+2, 3), a view into `texels`."""
        w = int(self.res[l]) + 2 * SAMPLE_BORDER
        off = int(self.offsets[l])
        return self.texels[off:off + 6 * w * w, :3].reshape(6 * w, w, 3)

    def bilinear(self, l: int, d: np.ndarray) -> np.ndarray:
        """Bilinear lookup of level l at directions (..., 3) → (..., 3) float64."""
        return bilinear_b1(self.level(l), int(self.res[l]), d)

    @classmethod
    def constant(cls, rgb, face_res: int = 1, levels: int = 1) -> "CubeChain":
        rgb = np.broadcast_to(np.asarray(rgb, np.float32), (3,))
        ims = []
        for lev in range(levels):
            n = max(1, face_res >> lev)
            ims.append(np.broadcast_to(rgb, (6 * (n + 2), n + 2, 3)).copy())
        return cls.from_levels(ims)


@dataclass
class GammaChain:
    """The accurate Γ_L pyramid (docs/ARTIFACTS.md, accurate path): per level the border-2
    B-spline coefficients of V and m interleaved as float4 pairs (2T, 4); offsets/res per level
    (offsets count texel pairs)."""

    texels: np.ndarray   # (2T, 4) float32: (V, 0), (m, 0) per texel
    offsets: np.ndarray  # (L,) int32 first texel (pair) of each level
    res: np.ndarray      # (L,) int32 face resolution (without border)

    @classmethod
    def from_levels(cls, values: list[np.ndarray], slopes: list[np.ndarray]) -> "GammaChain":
        """From `coef_LL` and `slope_LL` images, each (6·(n+4), n+4, 3)."""
        res, offs, parts, off = [], [], [], 0
        for v, m in zip(values, slopes, strict=True):
            v = np.asarray(v, np.float32)
            m = np.asarray(m, np.float32)
            w = v.shape[1]
            if v.ndim != 3 or v.shape[0] != 6 * w or w < 2 * COEF_BORDER + 1 or m.shape != v.shape:
                raise ValueError(f"not a border-2 cubemap level: shapes {v.shape}, {m.shape}")
            pair = np.zeros((v.shape[0] * w, 2, 4), np.float32)
            pair[:, 0, :3] = v[..., :3].reshape(-1, 3)
            pair[:, 1, :3] = m[..., :3].reshape(-1, 3)
            parts.append(pair.reshape(-1, 4))
            offs.append(off)
            res.append(w - 2 * COEF_BORDER)
            off += v.shape[0] * w
        return cls(np.concatenate(parts), np.asarray(offs, np.int32), np.asarray(res, np.int32))

    @classmethod
    def from_samples(cls, samples: list[np.ndarray], lambdas) -> "GammaChain":
        """Derived from plain V samples ("cube6v_b1" levels: folders or test environments
        without coef/slope files): V at the border-2 texel centres (stored samples, the outer
        ring sampled bilinearly at its own direction), m = ∂ln V/∂ln λ by central differences
        between neighbouring levels + ∂ln S/∂ln λ (exact for a constant map), both prefiltered
        to interpolating cubic B-spline coefficients."""
        lam = np.asarray(lambdas, np.float64)
        res = [np.asarray(s).shape[1] - 2 for s in samples]
        vals, slps = [], []
        for l, (smp, n) in enumerate(zip(samples, res)):
            d = bordered_dirs(n, COEF_BORDER)
            w = n + 2 * COEF_BORDER

            def at(k):
                return bilinear_b1(samples[k], res[k], d)
            v = at(l).reshape(6, w, w, 3)
            v[:, 1:-1, 1:-1] = np.asarray(smp, np.float64)[..., :3].reshape(6, n + 2, n + 2, 3)
            v = v.reshape(6 * w, w, 3)
            ka, kb = max(l - 1, 0), min(l + 1, len(samples) - 1)
            m = np.full_like(v, float(dln_sg_norm(lam[l])))
            if kb > ka:
                va = v if ka == l else at(ka)
                vb = v if kb == l else at(kb)
                ok = (va > 0) & (vb > 0)
                dv = (np.log(np.where(ok, va, 1.0)) - np.log(np.where(ok, vb, 1.0)))
                m += np.where(ok, dv / np.log(lam[ka] / lam[kb]), 0.0)
            vals.append(bspline_prefilter(v, n, COEF_BORDER))
            slps.append(bspline_prefilter(m, n, COEF_BORDER))
        return cls.from_levels(vals, slps)

    @classmethod
    def constant(cls, rgb, face_res: int, lambdas) -> "GammaChain":
        """A uniform map: V = rgb at every level, m = ∂ln S/∂ln λ (Γ_L = S(λ)·rgb)."""
        rgb = np.broadcast_to(np.asarray(rgb, np.float32), (3,))
        w = face_res + 2 * COEF_BORDER
        vals = [np.broadcast_to(rgb, (6 * w, w, 3)).copy() for _ in lambdas]
        slps = [np.full((6 * w, w, 3), dln_sg_norm(lam), np.float32) for lam in lambdas]
        return cls.from_levels(vals, slps)


@dataclass
class DpChain:
    """Dual-paraboloid MIP levels (Töral19 eq 11; "dp2h": (n, 2n, 3) each) in one float4
    buffer, the kernels' dpmap.h layout."""

    texels: np.ndarray   # (T, 4) float32
    offsets: np.ndarray  # (L,) int32
    res: np.ndarray      # (L,) int32 resolution n of each paraboloid
    b: float             # paraboloid scale (envmap.dp_scale)

    @classmethod
    def from_levels(cls, levels: list[np.ndarray], b: float) -> "DpChain":
        res, offs, parts, off = [], [], [], 0
        for img in levels:
            img = np.asarray(img, np.float32)
            n = img.shape[0]
            if img.ndim != 3 or img.shape[1] != 2 * n:
                raise ValueError(f"not a dual-paraboloid level: shape {img.shape}")
            rgba = np.zeros((2 * n * n, 4), np.float32)
            rgba[:, :3] = img[..., :3].reshape(-1, 3)
            parts.append(rgba)
            offs.append(off)
            res.append(n)
            off += len(rgba)
        return cls(np.concatenate(parts), np.asarray(offs, np.int32), np.asarray(res, np.int32),
                   float(b))

    @classmethod
    def from_cube(cls, mip: "CubeChain", b: float = 1.2, supersample: int = 2) -> "DpChain":
        """The envmap stage's chain from a cube chain's finest level, for environments built
        without the stage: paraboloids of the cube's resolution, each texel the solid-angle
        weighted mean of ss × ss bilinear cube samples (core.maps.dual_paraboloid_resample, as
        envmap.maps.cubemap_to_dual_paraboloid), then the solid-angle weighted box chain
        (envmap.mip.dp_mip_chain)."""
        from sgpipe.core.maps import (dual_paraboloid_resample, dual_paraboloid_solid_angles,
                                      solid_angle_box_chain)
        n = int(mip.res[0])
        level0 = mip.level(0)
        dp = dual_paraboloid_resample(lambda d: bilinear_b1(level0, n, d), n, b, supersample)
        chain = solid_angle_box_chain(dp, dual_paraboloid_solid_angles(n, b))
        return cls.from_levels([np.concatenate([lv[0], lv[1]], axis=1) for lv in chain], b)


@dataclass
class EnvData:
    """Everything the kernels need about distant lighting."""

    pyramid: CubeChain       # plain V samples ("cube6v_b1", the cheap path; tests, previews)
    lambdas: np.ndarray      # (L,) float32, strictly decreasing
    log_ratio: float         # ln(λ_l / λ_{l+1})
    mean: np.ndarray         # (3,) mean radiance over S² (the λ → 0 level)
    mip: CubeChain           # box MIP chain, level 0 finest (face res N)
    light_axes: np.ndarray   # (K, 3) world unit axes of the diffuse SG light fit
    light_lambda: np.ndarray  # (K,)
    light_mu: np.ndarray     # (K, 3)
    gamma: GammaChain | None = None   # accurate Γ_L chain (sg); derived from `pyramid` if None
    # point set beside the levels (pyramid.npz point_dirs / point_energy): Γ_L += Σ E e^{λ(c·p−1)}
    point_dirs: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    point_energy: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    # the unfiltered map of the levels' content (pyramid/raw.exr, one "cube6v_b1" level): the
    # λ → ∞ end of the sharp-side extrapolation; None: clamp to level 0
    raw: CubeChain | None = None
    # world ← map rotation (3, 3) of the whole environment (render.environment_rotation);
    # None: the identity. The arrays above stay in the map's frame.
    rotation: np.ndarray | None = None
    # the dual-paraboloid MIP chain (envmap/mip/dp_MM.exr; `gmm_toral19`); None: derived from
    # `mip` on first use (dp_chain)
    dp: DpChain | None = None

    def __post_init__(self):
        if self.gamma is None:
            p = self.pyramid
            self.gamma = GammaChain.from_samples([p.level(l) for l in range(len(p.res))],
                                                 self.lambdas)

    @property
    def mip_N(self) -> int:
        return int(self.mip.res[0])

    def dp_chain(self) -> DpChain:
        """The dual-paraboloid MIP chain (Töral19 eq 11): the envmap stage's, else derived."""
        if self.dp is None:
            self.dp = DpChain.from_cube(self.mip)
        return self.dp

    def rotated(self, rotation) -> "EnvData":
        """This environment turned by `rotation` (3, 3 world ← map; None: unchanged) after its
        own rotation; the arrays are shared, not copied."""
        R = checked_rotation(rotation)
        if R is None:
            return self
        if self.rotation is not None:
            R = R @ self.rotation
        return replace(self, rotation=None if np.array_equal(R, np.eye(3)) else R)

    def to_world(self, dirs: np.ndarray) -> np.ndarray:
        """Map-frame directions (..., 3) → world (R·d)."""
        d = np.asarray(dirs)
        return d if self.rotation is None else d @ self.rotation.T

    def to_map(self, dirs: np.ndarray) -> np.ndarray:
        """World directions (..., 3) → the map's frame (Rᵀ·d): where the maps are read."""
        d = np.asarray(dirs)
        return d if self.rotation is None else d @ self.rotation

    def rotation_defines(self) -> dict:
        """Compile-time defines of cubemap.h's `env_to_map` (M = Rᵀ, ENV_M<row><col>); {} for
        no rotation (the kernels then compile without it)."""
        if self.rotation is None:
            return {}
        M = self.rotation.T
        d = {"ENV_ROT": 1}
        d.update({f"ENV_M{i}{j}": float(M[i, j]) for i in range(3) for j in range(3)})
        return d

    def point_records(self) -> np.ndarray:
        """(max(K, 1), 2, 4) float32: (c_k, 0), (E_k, 0) per point, c_k in world directions —
        the kernels' layout."""
        k = len(self.point_dirs)
        rec = np.zeros((max(k, 1), 2, 4), np.float32)
        rec[:k, 0, :3] = self.to_world(np.asarray(self.point_dirs, np.float64))
        rec[:k, 1, :3] = self.point_energy
        return rec

    def residual_mip(self) -> CubeChain:
        """The box MIP chain (Töral19 eq 6–11) of the map minus the point set (`mip` minus the
        chain of the points' texels, mip level 0 − pyramid/raw.exr), so that a MIP lookup plus
        the points' exact vMF sum (gmm) counts every texel once. `mip` itself when there are no
        points (or no raw map, or another resolution)."""
        if not len(self.point_dirs) or self.raw is None or int(self.raw.res[0]) != self.mip_N:
            return self.mip
        from sgpipe.core.maps import bordered_box_level, cube_mip_chain, image_to_faces
        inner = lambda im: image_to_faces(np.asarray(im, np.float64))[:, 1:-1, 1:-1]  # noqa: E731
        # the points' texels (map − residual) through the same linear box chain, subtracted:
        # level 0 is the residual itself and the stage's borders stay as written
        pts = [bordered_box_level(f).astype(np.float32)    # the envmap stage's build_cube_chain
               for f in cube_mip_chain(inner(self.mip.level(0)) - inner(self.raw.level(0)))]
        out = []
        for l, lv in enumerate(pts):
            b = image_to_faces(np.asarray(lv, np.float64)).copy()
            # a face's corner border texel lies on a tie of two neighbouring faces, which
            # bordered_box_level breaks by axis order (not invariant under a turn of the map):
            # the points' part there is the mean of its two ring neighbours
            for i, j, di, dj in ((0, 0, 1, 1), (0, -1, 1, -1), (-1, 0, -1, 1), (-1, -1, -1, -1)):
                b[:, i, j] = 0.5 * (b[:, i + di, j] + b[:, i, j + dj])
            out.append(np.asarray(self.mip.level(l), np.float64) - b.reshape(lv.shape))
        return CubeChain.from_levels(out)

    def light_records(self, scale: float = 1.0) -> np.ndarray:
        """(K, 2, 4) float32: (world axis, λ), (μ·scale, 0) per lobe — the kernels' env_sg
        layout."""
        k = len(self.light_lambda)
        rec = np.zeros((max(k, 1), 2, 4), np.float32)
        if k:
            rec[:k, 0, :3] = self.to_world(np.asarray(self.light_axes, np.float64))
            rec[:k, 0, 3] = self.light_lambda
            rec[:k, 1, :3] = np.asarray(self.light_mu) * scale
        return rec

    @classmethod
    def constant(cls, rgb, face_res: int = 4) -> "EnvData":
        """A uniform environment of radiance `rgb` (white furnace), exact in all representations
        (Γ_L = S(λ)·rgb: V = rgb and m = ∂ln S/∂ln λ at every level)."""
        rgb = np.broadcast_to(np.asarray(rgb, np.float32), (3,)).copy()
        levels = max(1, int(np.log2(face_res)) + 1)
        lams = np.array([face_res ** 2 / 4.0, face_res ** 2 / 8.0], np.float32)
        # A λ → 0 SG is the constant: μ e^{λ(v·p−1)} → μ.
        return cls(pyramid=CubeChain.constant(rgb, face_res, 2), lambdas=lams,
                   log_ratio=float(np.log(2.0)), mean=rgb,
                   mip=CubeChain.constant(rgb, face_res, levels),
                   light_axes=np.array([[0.0, 1.0, 0.0]], np.float32),
                   light_lambda=np.array([1e-4], np.float32),
                   light_mu=rgb[None, :].copy(),
                   gamma=GammaChain.constant(rgb, face_res, lams.astype(np.float64)),
                   raw=CubeChain.constant(rgb, face_res, 1))

    @classmethod
    def load(cls, folder: str | Path, *, dual_paraboloid: bool = False) -> "EnvData":
        """Read `<out>/envmap/` (pyramid.npz + pyramid/{level,coef,slope}_LL.exr, mip.npz +
        mip/cube_MM.exr, light_sg.npz, and with `dual_paraboloid` mip/dp_MM.exr; readers of
        sgpipe.artifacts.envmap). Without coef/slope files the accurate chain is derived from
        the plain levels (GammaChain.from_samples)."""
        folder = Path(folder)
        if not folder.is_dir():
            raise BadInput("environment artifacts not found (run `sgpipe precompute` first)",
                           file=folder, key=contract.KEY)
        pyr = contract.read_pyramid(folder)
        mip = contract.read_mip(folder, "cube")
        dp = contract.read_mip(folder, "dp") if dual_paraboloid else None
        lsg = contract.read_light_sg(folder)
        f32 = np.float32
        return cls(pyramid=CubeChain.from_levels(pyr.samples), lambdas=pyr.lambdas.astype(f32),
                   log_ratio=float(np.log(pyr.ratio)), mean=np.asarray(pyr.mean, f32),
                   mip=CubeChain.from_levels(mip.levels),
                   light_axes=lsg.axes.astype(f32), light_lambda=lsg.sharpness.astype(f32),
                   light_mu=lsg.amplitude.astype(f32),
                   gamma=None if pyr.values is None else GammaChain.from_levels(pyr.values,
                                                                                pyr.slopes),
                   raw=None if pyr.raw is None else CubeChain.from_levels([pyr.raw]),
                   point_dirs=pyr.point_dirs.astype(f32),
                   point_energy=pyr.point_energy.astype(f32),
                   dp=None if dp is None else DpChain.from_levels(dp.levels, dp.b))
