"""GGX convolved with a vMF lobe of normals (Han07 eq 21 for GGX): the roughness α′ of the GGX
whose peak equals the convolution's, D′(μ) = ∫ vMF(n; μ, κ) D_α(n·μ) dn on the sphere.

Beckmann's slopes are Gaussian, so eq 21 adds variances exactly: α′² = α² + 2/κ. GGX's slopes
have no variance; in the plane of slopes (small angles) the peak of the convolution is that of
a GGX of α′² = α² + σ²(2 + 2/√(1 + 6.84 σ²/α²)), σ² = 1/κ (`slope_a2`: 4σ² for a narrow vMF,
the curvature of GGX's peak, 2σ² for a wide one), within 0.2 % for σ/α ≤ 1. On the sphere a
broad lobe's peak is higher (×1.3 at α 1, σ/α 0.3; ×2.7 at α 0.7, σ/α 2): the table holds
ln(α′²_sphere / slope_a2) on ln α × ln(σ/α), which the kernels read bilinearly (nm_shade.h
nm_convolved_a2). Beside it the table file keeps GGX's SG lobes per α (the roughness grid of
sgpipe.fit.ndf_sg_rough), which the normal-map kernels convolve with each vMF lobe
(nm_ggx_conv_lobes). `python -m sgpipe.core.ggx_conv` rewrites ggx_conv_table.npz.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: the table's nodes: ln α uniform on [ln A_MIN, 0], ln(σ/α) uniform on [ln R_MIN, ln R_MAX]
NA, NR = 25, 25
A_MIN, R_MIN, R_MAX = 0.003, 0.05, 20.0
TABLE = Path(__file__).with_name("ggx_conv_table.npz")


def slope_a2(a, kappa):
    """α′² of the peak-matched GGX in the plane of slopes (σ² = 1/κ)."""
    v = 1.0 / np.asarray(kappa, float)
    a = np.asarray(a, float)
    return a * a + v * (2.0 + 2.0 / np.sqrt(1.0 + 6.84 * v / (a * a)))


def ggx_d(c, a):
    """GGX D(h) at cos θ_h = c (0 below the horizon), normalised ∫ D cos θ_h dω = 1."""
    c = np.asarray(c, float)
    a2 = a * a
    d = c * c * (a2 - 1.0) + 1.0
    return np.where(c > 0, a2 / (math.pi * d * d), 0.0)


def convolved_peak(a: float, kappa: float) -> float:
    """∫ vMF(n; z, κ) D_α(n_z) dn (the convolution at the lobe's axis) by adaptive quadrature
    in θ, the lobes' widths as break points."""
    from scipy import integrate
    norm = kappa / (2.0 * math.pi * -math.expm1(-2.0 * kappa))

    def f(t):
        c = math.cos(t)
        return norm * math.exp(kappa * (c - 1.0)) * float(ggx_d(c, a)) * 2.0 * math.pi * math.sin(t)
    pts = sorted({min(a, 1.5), min(1.0 / math.sqrt(kappa), 1.5)})
    return integrate.quad(f, 0.0, 0.5 * math.pi, points=pts, limit=500, epsabs=0.0,
                          epsrel=1e-9)[0]


def sphere_a2(a: float, kappa: float) -> float:
    """α′² of the GGX whose peak 1/(π α′²) is convolved_peak."""
    return 1.0 / (math.pi * convolved_peak(a, kappa))


def node_values() -> tuple[np.ndarray, np.ndarray]:
    """The table's ln α (NA,) and ln(σ/α) (NR,) nodes."""
    return (np.linspace(math.log(A_MIN), 0.0, NA),
            np.linspace(math.log(R_MIN), math.log(R_MAX), NR))


def build_table() -> np.ndarray:
    """(NA, NR) ln(sphere_a2 / slope_a2) at the nodes."""
    la, lr = node_values()
    out = np.zeros((NA, NR))
    for i, x in enumerate(la):
        a = math.exp(x)
        for j, y in enumerate(lr):
            kappa = 1.0 / (a * math.exp(y)) ** 2
            out[i, j] = math.log(sphere_a2(a, kappa) / float(slope_a2(a, kappa)))
    return out


def load_table() -> np.ndarray:
    """The stored (NA, NR) ln(sphere_a2 / slope_a2)."""
    with np.load(TABLE, allow_pickle=False) as z:
        return np.asarray(z["log_ratio"], np.float64)


def load_lobes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stored GGX SG lobes: α (E,), sharpness (E, K), peak-normalised amplitude (E, K)."""
    with np.load(TABLE, allow_pickle=False) as z:
        return tuple(np.asarray(z[k], np.float64) for k in ("alpha", "sharpness", "amplitude"))


def build_lobes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """GGX's roughness grid (sgpipe.fit.ndf_sg_rough, the `sg` method's per-pixel lobes)."""
    from sgpipe.brdf.ndf import GGXNDF
    from sgpipe.fit.ndf_sg_rough import fit_roughness_grid
    g = fit_roughness_grid(GGXNDF)
    return g.alpha, g.sharpness, g.amplitude


def convolved_a2(a, kappa, table: np.ndarray | None = None):
    """α′² as the kernels compute it: slope_a2 × e^{bilinear table} (clamped to the grid)."""
    t = load_table() if table is None else table
    a = np.asarray(a, float)
    kappa = np.asarray(kappa, float)
    la, lr = node_values()
    x = np.clip((np.log(a) - la[0]) / (la[1] - la[0]), 0, NA - 1)
    y = np.clip((np.log(1.0 / (np.sqrt(kappa) * a)) - lr[0]) / (lr[1] - lr[0]), 0, NR - 1)
    i, j = np.minimum(x.astype(int), NA - 2), np.minimum(y.astype(int), NR - 2)
    fx, fy = x - i, y - j
    v = ((1 - fx) * (1 - fy) * t[i, j] + fx * (1 - fy) * t[i + 1, j]
         + (1 - fx) * fy * t[i, j + 1] + fx * fy * t[i + 1, j + 1])
    return slope_a2(a, kappa) * np.exp(v)


if __name__ == "__main__":
    tab = build_table()
    alpha, lam, mu = build_lobes()
    np.savez_compressed(TABLE, log_ratio=tab.astype(np.float32), alpha=alpha.astype(np.float32),
                        sharpness=lam.astype(np.float32), amplitude=mu.astype(np.float32))
    print(f"wrote {TABLE} ({NA} × {NR}); ratio {np.exp(tab.min()):.4f}–{np.exp(tab.max()):.4f}")
