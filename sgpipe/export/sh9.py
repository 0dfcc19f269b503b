"""SH9 irradiance (Ramamoorthi & Hanrahan 2001, the l ≤ 2 bands of Green06's SH light) as JSON:
E(n) = Σ_k E_k Y_k(n) with E_k = Â_l L_k, from the envmap stage's `light_sh.npz`."""

from __future__ import annotations

import math

import numpy as np

from sgpipe.artifacts.envmap import LIGHT_SH, read_light_sh
from sgpipe.errors import BadInput

# the nine real basis functions in world coordinates (x, y, z), +Y up: k = l(l + 1) + m
BASIS = ["0.282095", "0.488603 y", "0.488603 z", "0.488603 x", "1.092548 x y", "1.092548 y z",
         "0.315392 (3 z^2 - 1)", "1.092548 x z", "0.546274 (x^2 - y^2)"]
# Â_l of the clamped cosine: E_lm = Â_l L_lm
COSINE_BANDS = [math.pi, 2.0 * math.pi / 3.0, math.pi / 4.0]


def sh9_basis(d: np.ndarray) -> np.ndarray:
    """The nine basis functions of BASIS at unit directions (..., 3) → (..., 9), written out
    (the tests check them against sgpipe.core.sh.sh_eval)."""
    x, y, z = (np.asarray(d, float)[..., i] for i in range(3))
    c0, c1, c2 = 0.5 / math.sqrt(math.pi), math.sqrt(3.0 / (4.0 * math.pi)), \
        0.5 * math.sqrt(15.0 / math.pi)
    c20, c22 = 0.25 * math.sqrt(5.0 / math.pi), 0.25 * math.sqrt(15.0 / math.pi)
    return np.stack([np.full_like(x, c0), c1 * y, c1 * z, c1 * x, c2 * x * y, c2 * y * z,
                     c20 * (3.0 * z * z - 1.0), c2 * x * z, c22 * (x * x - y * y)], axis=-1)


def sh9_irradiance(irradiance_coeffs: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """E(n) = Σ_k E_k Y_k(n) for unit normals (..., 3), coefficients (9, 3) → (..., 3)."""
    return sh9_basis(normals) @ np.asarray(irradiance_coeffs, float)


def sh9_document(envmap_dir) -> dict:
    """The JSON document: the nine irradiance and radiance RGB coefficients and their
    convention, from `<envmap_dir>/light_sh.npz` (lmax ≥ 2)."""
    z = read_light_sh(envmap_dir)
    lmax = int(np.asarray(z["lmax"]).reshape(-1)[0])
    if lmax < 2:
        raise BadInput(f"lmax is {lmax}; SH9 needs the l ≤ 2 bands (envmap.sh_lmax ≥ 2)",
                       file=f"{envmap_dir}/{LIGHT_SH}", key="envmap.sh_lmax")
    irr = np.asarray(z["irradiance_coeffs"], float)[:9]
    rad = np.asarray(z["coeffs"], float)[:9]
    return {
        "format": "sgpipe SH9 irradiance 1",
        "convention": {
            "basis": "real orthonormal spherical harmonics, no Condon-Shortley phase, "
                     "order k = l(l+1)+m: [Y00, Y1-1, Y10, Y11, Y2-2, Y2-1, Y20, Y21, Y22]",
            "basis_functions": BASIS,
            "coordinates": "world (= glTF): right-handed, +Y up; (x, y, z) is the unit "
                           "direction, the SH pole is +Z",
            "normalisation": "orthonormal: integral of Y_k Y_j over the sphere = delta_kj",
            "irradiance": "cosine convolution applied: E_k = A_l L_k with A_0 = pi, "
                          "A_1 = 2 pi / 3, A_2 = pi / 4; E(n) = sum_k irradiance[k] Y_k(n) "
                          "in W m^-2 per unit radiance of the map; divide by pi for the "
                          "exit radiance of a white Lambertian surface",
            "radiance": "L_k = integral of L(w) Y_k(w) over the sphere (exact cube texel "
                        "solid angles)",
        },
        "irradiance": irr.tolist(),
        "radiance": rad.tolist(),
    }
