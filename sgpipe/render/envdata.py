"""Environment artifacts (`<out>/envmap/`, docs/ARTIFACTS.md envmap/) → packed arrays the
OpenCL kernels read: the normalised Γ_L pyramid (Wang09 eq 34–35), the box MIP chain (paper 000
eq 6–11, FIS) and the diffuse SG light fit (Wang09 §6). Read from disk, not via sgpipe.envmap.

Packed cubemap chain: float32 (T, 4) texels (RGB + 0), levels in order, each level in the
bordered "cube6v_b1" layout (6·(n+2) rows × (n+2) columns); `offsets[l]` is level l's first
texel, `res[l]` its face resolution n.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz


def scalar(a) -> float:
    """A stored scalar as float (sgpipe.io.write_npz currently stores () arrays as (1,))."""
    return float(np.asarray(a, np.float64).reshape(-1)[0])


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

    @classmethod
    def constant(cls, rgb, face_res: int = 1, levels: int = 1) -> "CubeChain":
        rgb = np.broadcast_to(np.asarray(rgb, np.float32), (3,))
        ims = []
        for lev in range(levels):
            n = max(1, face_res >> lev)
            ims.append(np.broadcast_to(rgb, (6 * (n + 2), n + 2, 3)).copy())
        return cls.from_levels(ims)


@dataclass
class EnvData:
    """Everything the kernels need about distant lighting."""

    pyramid: CubeChain
    lambdas: np.ndarray      # (L,) float32, strictly decreasing
    log_ratio: float         # ln(λ_l / λ_{l+1})
    mean: np.ndarray         # (3,) mean radiance over S² (the λ → 0 level)
    mip: CubeChain           # box MIP chain, level 0 finest (face res N)
    light_axes: np.ndarray   # (K, 3) world unit axes of the diffuse SG light fit
    light_lambda: np.ndarray  # (K,)
    light_mu: np.ndarray     # (K, 3)

    @property
    def mip_N(self) -> int:
        return int(self.mip.res[0])

    def light_records(self, scale: float = 1.0) -> np.ndarray:
        """(K, 2, 4) float32: (axis, λ), (μ·scale, 0) per lobe — the kernels' env_sg layout."""
        k = len(self.light_lambda)
        rec = np.zeros((max(k, 1), 2, 4), np.float32)
        if k:
            rec[:k, 0, :3] = self.light_axes
            rec[:k, 0, 3] = self.light_lambda
            rec[:k, 1, :3] = np.asarray(self.light_mu) * scale
        return rec

    @classmethod
    def constant(cls, rgb, face_res: int = 4) -> "EnvData":
        """A uniform environment of radiance `rgb` (white furnace), exact in all representations."""
        rgb = np.broadcast_to(np.asarray(rgb, np.float32), (3,)).copy()
        levels = max(1, int(np.log2(face_res)) + 1)
        # A λ → 0 SG is the constant: μ e^{λ(v·p−1)} → μ.
        return cls(pyramid=CubeChain.constant(rgb, face_res, 2),
                   lambdas=np.array([face_res ** 2 / 4.0, face_res ** 2 / 8.0], np.float32),
                   log_ratio=float(np.log(2.0)), mean=rgb,
                   mip=CubeChain.constant(rgb, face_res, levels),
                   light_axes=np.array([[0.0, 1.0, 0.0]], np.float32),
                   light_lambda=np.array([1e-4], np.float32),
                   light_mu=rgb[None, :].copy())

    @classmethod
    def load(cls, folder: str | Path) -> "EnvData":
        """Read `<out>/envmap/` (pyramid.npz + pyramid/level_LL.exr, mip.npz + mip/cube_MM.exr,
        light_sg.npz)."""
        folder = Path(folder)
        if not folder.is_dir():
            raise BadInput("environment artifacts not found (run `sgpipe precompute` first)",
                           file=folder, key="envmap")
        idx = read_npz(folder / "pyramid.npz", required=("lambdas", "face_res", "mean"),
                       key="envmap")
        lam = np.asarray(idx["lambdas"], np.float64)
        levels = [read_exr(folder / "pyramid" / f"level_{i:02d}.exr", channels=(3, 4),
                           key="envmap")[..., :3] for i in range(len(lam))]
        ratio = scalar(idx["ratio"]) if "ratio" in idx else (
            float(lam[0] / lam[1]) if len(lam) > 1 else 2.0)
        mip_idx = read_npz(folder / "mip.npz", required=("cube_res",), key="envmap")
        mips = [read_exr(folder / "mip" / f"cube_{i:02d}.exr", channels=(3, 4),
                         key="envmap")[..., :3] for i in range(len(mip_idx["cube_res"]))]
        lsg = read_npz(folder / "light_sg.npz", required=("axes", "sharpness", "amplitude"),
                       key="envmap")
        return cls(pyramid=CubeChain.from_levels(levels), lambdas=lam.astype(np.float32),
                   log_ratio=float(np.log(ratio)), mean=np.asarray(idx["mean"], np.float32),
                   mip=CubeChain.from_levels(mips),
                   light_axes=np.asarray(lsg["axes"], np.float32).reshape(-1, 3),
                   light_lambda=np.asarray(lsg["sharpness"], np.float32).reshape(-1),
                   light_mu=np.asarray(lsg["amplitude"], np.float32).reshape(-1, 3))
