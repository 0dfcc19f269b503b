"""A built or loaded Γ_L pyramid and its reference lookups (Wang09 eq 35; docs/ARTIFACTS.md,
`envmap/`): V_ℓ = Γ_L(·, λ_ℓ)/S(λ_ℓ) and the log-slope m_ℓ = ∂ln Γ_L/∂ln λ per level as cubic
B-spline coefficients, a cubic Hermite of ln Γ_L in ln λ between levels, the exact point set
added at any λ."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sgpipe.artifacts.envmap import COEF_BORDER as BORDER
from sgpipe.core.sg import dln_sg_norm, sg_integral
from sgpipe.core.vmf import mean_resultant_length
from sgpipe.envmap._cube_jit import sample_bordered


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
        P, lamv, lam, shape = _flatten(p, lam)
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
                w = _broad_weight(lamv[sel], self.lambdas[-1])
                va = np.where(x[sel, None] > L - 1, self.mean + w * (va - self.mean), va)
            out[sel] = va
        return self._with_points(out, P, lamv, lam, shape, normalized)

    def lookup(self, p, lam, *, normalized: bool = False) -> np.ndarray:
        """⟨G(·; p, λ, 1), L⟩ = Γ_L(p, λ) (Wang09 eq 35) for unit p (..., 3) and λ (broadcast);
        normalized=True returns V = Γ_L/S(λ) (a weighted mean radiance). Returns (..., 3).
        Cubic B-spline in p, cubic Hermite of ln Γ_L in ln λ (the accurate path)."""
        P, lamv, lam, shape = _flatten(p, lam)
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
            w = _broad_weight(lamv[broad], self.lambdas[-1])
            out[broad] = self.mean + w * (vl - self.mean)
        if mid.any():
            idx = np.nonzero(mid)[0]
            lev = np.minimum(np.floor(x[idx]).astype(int), L - 2)
            for l in np.unique(lev):
                sel = idx[lev == l]
                out[sel] = self._hermite(l, P[sel], lamv[sel], x[sel] - l)
        return self._with_points(out, P, lamv, lam, shape, normalized)

    def _with_points(self, out, P, lamv, lam, shape, normalized: bool) -> np.ndarray:
        """V of the levels (M, 3) plus the point set's, reshaped to `shape` + (3,); Γ_L = S·V
        unless `normalized`."""
        out += self.points_gamma(P, lamv) / sg_integral(lamv, 1.0)[:, None]
        out = out.reshape(shape + (3,))
        if normalized:
            return out
        return out * np.broadcast_to(sg_integral(lam, 1.0), shape)[..., None]

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


def _flatten(p, lam):
    """(P (M, 3) contiguous, λ (M,), λ as an array, the broadcast shape) of lookup arguments."""
    p = np.asarray(p, float)
    lam = np.asarray(lam, float)
    shape = np.broadcast_shapes(p.shape[:-1], lam.shape)
    P = np.ascontiguousarray(np.broadcast_to(p, shape + (3,)).reshape(-1, 3))
    return P, np.broadcast_to(lam, shape).reshape(-1), lam, shape


def _broad_weight(lam, lam_last):
    """(M, 1) weight A(λ)/A(λ_{L−1}) of the broadest level's deviation from the mean below it
    (A: the l = 1 response of the normalized SG, `core.vmf.mean_resultant_length`)."""
    return (mean_resultant_length(lam) / mean_resultant_length(lam_last))[:, None]


def hermite_ln(va, ma, la, vb, mb, lb, lam, t):
    """V at λ (t ∈ [0, 1] its position in ln λ between la and lb) from a cubic Hermite of
    y = ln Γ = ln(S·V) in u = ln λ with end slopes m (per channel); linear V where V ≤ 0."""
    t = np.asarray(t, float)[:, None]
    lin = (1.0 - t) * va + t * vb
    ok = (va > 0) & (vb > 0)
    ya = np.log(np.where(ok, va, 1.0) * sg_integral(la, 1.0))
    yb = np.log(np.where(ok, vb, 1.0) * sg_integral(lb, 1.0))
    du = math.log(lb / la)
    t2 = t * t
    t3 = t2 * t
    y = ((2 * t3 - 3 * t2 + 1) * ya + (t3 - 2 * t2 + t) * du * ma
         + (-2 * t3 + 3 * t2) * yb + (t3 - t2) * du * mb)
    herm = np.exp(y) / sg_integral(lam, 1.0)[:, None]
    return np.where(ok, herm, lin)
