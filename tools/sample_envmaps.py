"""Procedural HDR lat-long environment maps for data_samples/ (sky + sun, studio, white).

Lat-long convention (docs/CONVENTIONS.md): texel (row i, column j) of an H x W map covers
theta in [pi i/H, pi (i+1)/H], phi in [2 pi j/W, 2 pi (j+1)/W], direction
(sin t sin p, cos t, -sin t cos p). Every texel value is the mean radiance over its footprint,
estimated with equal-solid-angle strata (uniform in phi and cos theta), so integrals computed
as sum(texel * exact texel solid angle) reproduce the analytic integrals.
"""

from __future__ import annotations

import numpy as np

from canonical import cross3, dot3


def direction(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Unit direction for polar angle theta (from +Y) and azimuth phi (CONVENTIONS lat-long)."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, np.float64), np.asarray(phi, np.float64))
    st = np.sin(theta)
    return np.stack([st * np.sin(phi), np.cos(theta), -st * np.cos(phi)], -1)


def texel_solid_angles(h: int, w: int) -> np.ndarray:
    """Exact solid angle of each texel, (h, w): (2 pi / w) (cos theta_i - cos theta_{i+1})."""
    ct = np.cos(np.pi * np.arange(h + 1) / h)
    return np.repeat(((2.0 * np.pi / w) * (ct[:-1] - ct[1:]))[:, None], w, axis=1)


def texel_cos_weights(h: int, w: int) -> np.ndarray:
    """Exact integral of max(cos theta, 0) over each texel, (h, w): for irradiance at normal +Y."""
    ct = np.clip(np.cos(np.pi * np.arange(h + 1) / h), 0.0, None)
    return np.repeat(((2.0 * np.pi / w) * 0.5 * (ct[:-1] ** 2 - ct[1:] ** 2))[:, None], w, axis=1)


def texel_centre_dirs(h: int, w: int) -> np.ndarray:
    """Direction through each texel centre, (h, w, 3)."""
    theta = np.pi * (np.arange(h) + 0.5) / h
    phi = 2.0 * np.pi * (np.arange(w) + 0.5) / w
    return direction(theta[:, None], phi[None, :])


def strata_dirs(rows: np.ndarray, cols: np.ndarray, h: int, w: int, n: int) -> np.ndarray:
    """n x n equal-solid-angle sample directions inside texels (rows[k], cols[k]): (K, n*n, 3)."""
    s = (np.arange(n) + 0.5) / n
    c0 = np.cos(np.pi * rows / h)[:, None]
    c1 = np.cos(np.pi * (rows + 1) / h)[:, None]
    z = c0 + (c1 - c0) * s[None, :]                                   # (K, n) cos theta
    phi = 2.0 * np.pi * (cols[:, None] + s[None, :]) / w              # (K, n)
    z = np.repeat(z, n, axis=1)
    phi = np.tile(phi, (1, n))
    st = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    return np.stack([st * np.sin(phi), z, -st * np.cos(phi)], -1)


def supersample(fns, h: int, w: int, n: int, *, rows_per_chunk: int = 16) -> list[np.ndarray]:
    """Texel means of each fn(dirs (..., 3)) -> (..., 3) over an h x w map with n x n strata."""
    outs = [np.zeros((h, w, 3)) for _ in fns]
    for r0 in range(0, h, rows_per_chunk):
        rr, cc = np.meshgrid(np.arange(r0, min(h, r0 + rows_per_chunk)), np.arange(w),
                             indexing="ij")
        d = strata_dirs(rr.ravel().astype(float), cc.ravel().astype(float), h, w, n)
        for fn, out in zip(fns, outs):
            out[rr, cc] = fn(d).mean(axis=1).reshape(rr.shape + (3,))
    return outs


# ---------------------------------------------------------------- sky + sun

SKY = {
    "zenith_rgb": (0.20, 0.38, 0.85),
    "horizon_rgb": (0.85, 0.90, 1.00),
    "ground_rgb": (0.22, 0.19, 0.15),
    "horizon_exponent": 4.0,
    "glow_gain": 1.5,       # sky *= 1 + gain * ((1 + d.s) / 2)^power: broad brightening sunward
    "glow_power": 16.0,
}
SUN = {
    "elevation_deg": 35.0,
    "phi_deg": 110.0,
    "angular_radius_deg": 0.75,
    "radiance": 5.0e4,
    "color": (1.0, 0.92, 0.82),
}


def sky_radiance(d: np.ndarray) -> np.ndarray:
    """Sky gradient above the horizon (zenith -> horizon blend with weight (1 - y)^4, brighter
    toward the sun) and a ground below it that darkens toward the nadir."""
    y = d[..., 1:2]
    zen, hor, gnd = (np.asarray(SKY[k]) for k in ("zenith_rgb", "horizon_rgb", "ground_rgb"))
    wgt = (1.0 - np.clip(y, 0.0, 1.0)) ** SKY["horizon_exponent"]
    glow = (0.5 * (1.0 + dot3(d, sun_geometry()["direction"])))[..., None] ** SKY["glow_power"]
    sky = (zen + (hor - zen) * wgt) * (1.0 + SKY["glow_gain"] * glow)
    ground = gnd * (1.0 + 0.3 * np.clip(y, -1.0, 0.0))
    return np.where(y >= 0.0, sky, ground)


def sun_geometry() -> dict:
    """Sun direction, cap solid angle 2 pi (1 - cos r), radiance, power L*Omega and the
    irradiance L pi sin^2 r it gives a surface facing it."""
    theta = np.radians(90.0 - SUN["elevation_deg"])
    phi = np.radians(SUN["phi_deg"])
    r = np.radians(SUN["angular_radius_deg"])
    radiance = SUN["radiance"] * np.asarray(SUN["color"])
    omega = 2.0 * np.pi * (1.0 - np.cos(r))
    return {
        "direction": direction(theta, phi),
        "cos_radius": np.cos(r),
        "solid_angle_sr": omega,
        "radiance_rgb": radiance,
        "power_rgb": radiance * omega,
        "irradiance_facing_rgb": radiance * np.pi * np.sin(r) ** 2,
    }


def sun_coverage(h: int, w: int, n: int = 64) -> np.ndarray:
    """Fraction of each texel's solid angle inside the sun's cap, (h, w); n x n strata on the
    texels near the sun, zero elsewhere."""
    g = sun_geometry()
    s, cos_r = g["direction"], g["cos_radius"]
    centres = texel_centre_dirs(h, w)
    margin = np.arccos(np.clip(cos_r, -1, 1)) + 2.0 * np.pi / min(h, w / 2) * 2.0
    rows, cols = np.nonzero(dot3(centres, s) > np.cos(margin))
    cov = np.zeros((h, w))
    d = strata_dirs(rows.astype(float), cols.astype(float), h, w, n)
    cov[rows, cols] = (dot3(d, s) > cos_r).mean(axis=1)
    return cov


def make_sky_sun(h: int = 256, w: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """(sky only, sky + sun) maps, float64 (h, w, 3); the sun is added on top of the sky."""
    (sky,) = supersample([sky_radiance], h, w, 4)
    sun = sun_coverage(h, w)[..., None] * sun_geometry()["radiance_rgb"]
    return sky, sky + sun


# ---------------------------------------------------------------- studio

STUDIO_BACKGROUND_RGB = (0.030, 0.030, 0.034)  # times (1 + 0.5 y): integral is 4 pi * this
SOFTBOXES = (
    {"name": "key", "elevation_deg": 40.0, "phi_deg": 60.0, "half_width_deg": 18.0,
     "half_height_deg": 12.0, "radiance_rgb": (14.0, 11.5, 8.0)},
    {"name": "fill", "elevation_deg": 10.0, "phi_deg": 290.0, "half_width_deg": 24.0,
     "half_height_deg": 16.0, "radiance_rgb": (2.0, 3.0, 5.0)},
    {"name": "rim", "elevation_deg": 20.0, "phi_deg": 180.0, "half_width_deg": 6.0,
     "half_height_deg": 22.0, "radiance_rgb": (6.0, 1.5, 4.5)},
    {"name": "top", "elevation_deg": 90.0, "phi_deg": 0.0, "half_width_deg": 25.0,
     "half_height_deg": 8.0, "radiance_rgb": (2.5, 3.0, 2.5)},
)


def softbox_frame(box: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre c, width axis e1 = azimuthal direction (cos phi, 0, sin phi), height axis c x e1."""
    theta = np.radians(90.0 - box["elevation_deg"])
    phi = np.radians(box["phi_deg"])
    c = direction(theta, phi)
    e1 = np.array([np.cos(phi), 0.0, np.sin(phi)])
    return c, e1, cross3(c, e1)


def softbox_solid_angle(box: dict) -> float:
    """Solid angle of a planar rectangle seen from its centre normal at unit distance, half
    sides a = tan(half width), b = tan(half height): 4 atan(a b / sqrt(1 + a^2 + b^2))."""
    a = np.tan(np.radians(box["half_width_deg"]))
    b = np.tan(np.radians(box["half_height_deg"]))
    return float(4.0 * np.arctan(a * b / np.sqrt(1.0 + a * a + b * b)))


def softbox_mask(box: dict, d: np.ndarray) -> np.ndarray:
    """1 where d sees the rectangle (gnomonic projection inside the half-tangents), else 0."""
    c, e1, e2 = softbox_frame(box)
    a = np.tan(np.radians(box["half_width_deg"]))
    b = np.tan(np.radians(box["half_height_deg"]))
    dc, d1, d2 = dot3(d, c), dot3(d, e1), dot3(d, e2)
    return ((dc > 0) & (np.abs(d1) <= a * dc) & (np.abs(d2) <= b * dc)).astype(np.float64)


def make_studio(h: int = 256, w: int = 512, n: int = 8) -> tuple[np.ndarray, list[np.ndarray]]:
    """Studio map (h, w, 3) and each softbox's own texel contribution (for the sidecar)."""
    base = np.asarray(STUDIO_BACKGROUND_RGB)
    fns = [lambda d: base * (1.0 + 0.5 * d[..., 1:2])]
    for box in SOFTBOXES:
        rad = np.asarray(box["radiance_rgb"])
        fns.append(lambda d, box=box, rad=rad: softbox_mask(box, d)[..., None] * rad)
    background, *parts = supersample(fns, h, w, n)
    return background + sum(parts), parts
