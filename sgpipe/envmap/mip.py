"""Töral19's lobe-sized MIP lookup (eq 6–11) and the filtered-importance-sampling lod of
Colbert & Křivánek (GPU Gems 3 ch 20), on box-filtered cubemap and dual-paraboloid MIP chains."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sgpipe.core.maps import (bordered_box_level, cube_mip_chain, dual_paraboloid_distortion,
                              dual_paraboloid_solid_angles, solid_angle_box_chain)
from sgpipe.envmap._cube_jit import sample_dirs_bordered
from sgpipe.envmap.maps import image_to_dual_paraboloid, sample_dual_paraboloid


def dp_mip_chain(dp: np.ndarray, b: float) -> list[np.ndarray]:
    """Box MIP chain of a dual-paraboloid map (2, n, n, C), solid-angle weighted."""
    return solid_angle_box_chain(dp, dual_paraboloid_solid_angles(np.shape(dp)[1], b))


def lobe_solid_angle(kappa, a: float = 0.9):
    """Töral19 eq 8: Ω_s = −2π ln(1 − a)/κ, the solid angle holding a fraction a of the lobe."""
    return -2.0 * np.pi * math.log(1.0 - a) / np.asarray(kappa, float)


def cube_distortion(d):
    """Cubemap analogue of Töral19's d(i): exact texel solid angle = D(d)/N² with
    D(d) = 4·max(|d_x|, |d_y|, |d_z|)³ (gnomonic face: dω = dA·cos³ of the angle to the axis)."""
    d = np.asarray(d, float)
    return 4.0 * np.max(np.abs(d), axis=-1) ** 3


@dataclass
class MipChain:
    """A box-filtered MIP chain with Töral19's lod rule (eq 10) and trilinear lookup.

    kind "cube": levels are bordered cube strips (6·(n+2), n+2, 3); kind "dp": (n, 2n, 3).
    """

    kind: str
    levels: list[np.ndarray]
    b: float = 1.0

    @property
    def res(self) -> list[int]:
        return [lv.shape[1] - 2 if self.kind == "cube" else lv.shape[0] for lv in self.levels]

    @property
    def n_finest(self) -> int:
        return self.res[0]

    def texel_solid_angle(self, d) -> np.ndarray:
        """Eq 9: Ω_p = D(d)/(w·h), w = h = finest face/paraboloid resolution."""
        dist = cube_distortion(d) if self.kind == "cube" else dual_paraboloid_distortion(d, self.b)
        return dist / float(self.n_finest) ** 2

    def lobe_lod(self, d, kappa, a: float = 0.9) -> np.ndarray:
        """Eq 10: lod = ½ log2(Ω_s/Ω_p) for a lobe of sharpness κ at direction d (clamped)."""
        lod = 0.5 * np.log2(lobe_solid_angle(kappa, a) / self.texel_solid_angle(d))
        return np.clip(lod, 0.0, len(self.levels) - 1)

    def fis_lod(self, d, pdf, n_samples: int) -> np.ndarray:
        """Colbert–Křivánek: Ω_s = 1/(N·pdf), lod = max(½ log2(Ω_s/Ω_p) + 1, 0) (clamped)."""
        om_s = 1.0 / (float(n_samples) * np.maximum(np.asarray(pdf, float), 1e-300))
        lod = 0.5 * np.log2(om_s / self.texel_solid_angle(d)) + 1.0
        return np.clip(lod, 0.0, len(self.levels) - 1)

    def level_lookup(self, level: int, d) -> np.ndarray:
        d = np.ascontiguousarray(np.asarray(d, float).reshape(-1, 3))
        lv = self.levels[level]
        if self.kind == "cube":
            return sample_dirs_bordered(lv, lv.shape[1] - 2, 1, d, False)
        return sample_dual_paraboloid(image_to_dual_paraboloid(lv), d, self.b)

    def lookup(self, d, lod) -> np.ndarray:
        """Trilinear: bilinear in the two MIP levels around `lod`, linear between them."""
        d = np.asarray(d, float)
        shape = d.shape[:-1]
        D = d.reshape(-1, 3)
        lod = np.broadcast_to(np.clip(np.asarray(lod, float), 0, len(self.levels) - 1),
                              shape).reshape(-1)
        lo = np.floor(lod).astype(int)
        hi = np.minimum(lo + 1, len(self.levels) - 1)
        t = (lod - lo)[:, None]
        out = np.zeros((len(D), 3))
        for level in np.unique(np.concatenate([lo, hi])):
            wl = np.where(lo == level, 1.0 - t[:, 0], 0.0) + np.where(hi == level, t[:, 0], 0.0)
            sel = wl > 0
            if sel.any():
                out[sel] += wl[sel, None] * self.level_lookup(level, D[sel])
        return out.reshape(shape + (3,))

    def lobe_lookup(self, d, kappa, a: float = 0.9) -> np.ndarray:
        """Töral19 §V: radiance averaged over the lobe's footprint (the MIP texel at its lod)."""
        return self.lookup(d, self.lobe_lod(d, kappa, a))

    def lobe_integral(self, d, kappa, taps: int = 16, c: float = 1.0) -> np.ndarray:
        """∫vMF(ω; d, κ) L(ω) dω by `taps` trilinear fetches (the gmm kernel's lookup, eq 6–10
        made lobe-shaped): level with texel h = c·σ (σ² = 1/κ), taps at the radial quantiles of a
        vMF of variance σ² − v_f (v_f = h²/4 of the box+bilinear filter), golden-angle azimuths."""
        d = np.asarray(d, float).reshape(-1, 3)
        kappa = np.broadcast_to(np.asarray(kappa, float), (len(d),))
        sig2 = 1.0 / np.maximum(kappa, 1e-4)
        om0 = self.texel_solid_angle(d)
        lod = np.clip(0.5 * np.log2(c * c * sig2 / om0), 0.0, len(self.levels) - 1)
        l0 = np.floor(lod)
        vf = 0.25 * om0 * 4.0 ** l0 * (1.0 + 3.0 * (lod - l0))
        kp = 1.0 / np.maximum(sig2 - vf, 0.1 * sig2)
        s = np.where(d[:, 2] >= 0, 1.0, -1.0)
        p = -1.0 / (s + d[:, 2])
        q = d[:, 0] * d[:, 1] * p
        bu = np.stack([1 + s * d[:, 0] ** 2 * p, s * q, -s * d[:, 0]], -1)
        bv = np.stack([q, s + d[:, 1] ** 2 * p, -d[:, 1]], -1)
        acc = np.zeros((len(d), 3))
        golden = np.pi * (3.0 - math.sqrt(5.0))
        for i in range(taps):
            u = (i + 0.5) / taps
            w = np.clip(1.0 + np.log(u + (1.0 - u) * np.exp(-2.0 * kp)) / kp, -1.0, 1.0)
            r = np.sqrt(np.maximum(0.0, 1.0 - w * w))[:, None]
            x = r * (math.cos(-golden * i) * bu + math.sin(-golden * i) * bv) + w[:, None] * d
            acc += self.lookup(x / np.linalg.norm(x, axis=1, keepdims=True), lod)
        acc /= taps
        # a lobe within the finest texel's filter: one bilinear fetch (the taps' limit)
        sharp = (sig2 <= 0.5 * vf) & (lod <= 0.0)
        if sharp.any():
            acc[sharp] = self.level_lookup(0, d[sharp])
        return acc


def build_cube_chain(faces: np.ndarray) -> MipChain:
    return MipChain("cube", [bordered_box_level(f).astype(np.float32)
                             for f in cube_mip_chain(faces)])


def build_dp_chain(dp: np.ndarray, b: float) -> MipChain:
    from sgpipe.envmap.maps import dual_paraboloid_to_image
    return MipChain("dp", [dual_paraboloid_to_image(f).astype(np.float32)
                           for f in dp_mip_chain(dp, b)], b=b)
