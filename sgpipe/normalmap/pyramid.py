"""The MIP pyramid of a normal map: which normals each texel covers (Han07 §4.1, the NDF γ of
eq 5/9 is the sum of their deltas), their mean, and the single-lobe baselines built from it:
the normalised MIP of normals, Toksvig's factor (2005) and the engine roughness bake
(κ from the mean length r, α′ = √(α² + 2/κ), Han07 eq 21 with σ = α/2)."""

from __future__ import annotations

import numpy as np

from sgpipe.core.vmf import kappa_from_rbar


def level_count(side: int, levels: int | None = None) -> int:
    """MIP levels of a side × side map (side a power of two): down to 1×1, or `levels`."""
    full = int(side).bit_length()          # log2(side) + 1
    return full if levels is None else max(1, min(int(levels), full))


def texel_normals(normals: np.ndarray, level: int, row: int, col: int) -> np.ndarray:
    """The NDF γ of texel (row, col) at `level` as its samples: the 4^level finest normals it
    covers (Han07 §4.1: γ = (1/N) Σ_q δ(n − n(q))), (4^level, 3)."""
    b = 1 << level
    return np.asarray(normals[row * b:(row + 1) * b, col * b:(col + 1) * b]).reshape(-1, 3)


def box_down(a: np.ndarray) -> np.ndarray:
    """One MIP step: the mean of each 2×2 block (..., fixed summation order: deterministic)."""
    return 0.25 * ((a[0::2, 0::2] + a[0::2, 1::2]) + (a[1::2, 0::2] + a[1::2, 1::2]))


def mean_normal_pyramid(normals: np.ndarray, levels: int | None = None) -> list[np.ndarray]:
    """Per level the (unnormalised) mean of the covered unit normals, (side_l, side_l, 3): the
    plain MIP-map of normals, whose length r ≤ 1 measures the NDF's spread."""
    out = [np.asarray(normals, np.float64)]
    for _ in range(1, level_count(normals.shape[0], levels)):
        out.append(box_down(out[-1]))
    return out


def _length(v: np.ndarray) -> np.ndarray:
    return np.sqrt(v[..., 0] ** 2 + v[..., 1] ** 2 + v[..., 2] ** 2)


def normalized_mip(mean: np.ndarray) -> np.ndarray:
    """Normalised MIP-mapping of normals: mean / |mean| (the 'flat' baseline of Han07 Fig 1e)."""
    return mean / np.maximum(_length(mean), 1e-300)[..., None]


def toksvig_factor(mean: np.ndarray, exponent: float) -> np.ndarray:
    """Toksvig 2005: f_t = |n̄| / (|n̄| + s(1 − |n̄|)); the shading exponent becomes f_t · s."""
    r = _length(mean)
    return r / (r + float(exponent) * (1.0 - r))


def engine_kappa(mean: np.ndarray, kappa_max: float) -> np.ndarray:
    """κ of the single vMF whose mean resultant length is |n̄|: (3r − r³)/(1 − r²) (Banerjee's
    approximation, as Filament's and Godot's roughness prefilters use), capped at kappa_max."""
    return np.minimum(kappa_from_rbar(np.minimum(_length(mean), 1.0)), float(kappa_max))


def engine_roughness(mean: np.ndarray, alpha: float, kappa_max: float) -> np.ndarray:
    """The engine bake α′ = √(α² + 2/κ) (Han07 eq 21 for Beckmann α = 2σ)."""
    return np.sqrt(float(alpha) ** 2 + 2.0 / engine_kappa(mean, kappa_max))
