"""The fidelity corpus's generated inputs: lat-long maps (hard-edged lamps, sky + sun, a mixed
map), a thick bowl mesh and a v-groove normal map.

Every generator is a pure function of its arguments (a `numpy.random.Generator` drawn from the
scene's seed where something is random), so a corpus seed gives byte-identical files. Lat-long
maps follow docs/CONVENTIONS.md and store each texel's mean radiance over its footprint
(equal-solid-angle strata), as data_samples/ does, so Σ texel · Ω_texel is the map's power.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

ENV_H, ENV_W = 256, 512
#: Background radiance of the lamp maps (× (1 + 0.5 y)); lamps are 10²–10⁴ × this.
LAMP_AMBIENT = 0.02


def _dir(theta, phi):
    """CONVENTIONS lat-long direction (sin θ sin φ, cos θ, −sin θ cos φ)."""
    st = np.sin(theta)
    return np.stack([st * np.sin(phi), np.cos(theta) + 0.0 * phi, -st * np.cos(phi)], -1)


def texel_means(fn, h: int = ENV_H, w: int = ENV_W, n: int = 4, rows=None) -> np.ndarray:
    """(h, w, 3) mean of fn(dirs (..., 3)) → (..., 3) over each texel, n × n strata uniform in
    φ and cos θ (equal solid angle); `rows` restricts the work to those rows (others 0)."""
    out = np.zeros((h, w, 3))
    s = (np.arange(n) + 0.5) / n
    phi = 2.0 * np.pi * (np.arange(w)[:, None] + s[None, :]) / w            # (w, n)
    for i in (range(h) if rows is None else rows):
        c0, c1 = math.cos(math.pi * i / h), math.cos(math.pi * (i + 1) / h)
        theta = np.arccos(np.clip(c0 + (c1 - c0) * s, -1.0, 1.0))             # (n,)
        d = _dir(theta[None, :, None], phi[:, None, :])                       # (w, n, n, 3)
        out[i] = fn(d).reshape(w, n * n, 3).mean(axis=1)
    return out


def _unit(v) -> np.ndarray:
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


def elevation_dir(elevation_deg: float, phi_deg: float) -> np.ndarray:
    """The direction at `elevation_deg` above the horizon and azimuth φ = `phi_deg`."""
    return _dir(np.radians(90.0 - elevation_deg), np.radians(phi_deg))


# -- environment maps --------------------------------------------------------------------------

def draw_lamps(rng: np.random.Generator, count: int) -> list[dict]:
    """`count` rectangular lamps: centre elevation 5–80°, any azimuth, half sides 2–14° by
    2–9°, a roll about the centre, radiance 10²–10⁴ × LAMP_AMBIENT in a random warm/cool tint."""
    lamps = []
    for _ in range(count):
        tint = np.array([1.0, 1.0, 1.0]) + rng.uniform(-0.35, 0.35, 3)
        lamps.append({"elevation_deg": float(rng.uniform(5.0, 80.0)),
                      "phi_deg": float(rng.uniform(0.0, 360.0)),
                      "half_width_deg": float(rng.uniform(2.0, 14.0)),
                      "half_height_deg": float(rng.uniform(2.0, 9.0)),
                      "roll_deg": float(rng.uniform(0.0, 180.0)),
                      "radiance": (LAMP_AMBIENT * 10.0 ** rng.uniform(2.0, 4.0)
                                   * tint / tint.mean()).tolist()})
    return lamps


def lamp_mask(lamp: dict, d: np.ndarray) -> np.ndarray:
    """1 where d sees the planar rectangle (gnomonic: |d·e1| ≤ a d·c, |d·e2| ≤ b d·c), else 0."""
    c = elevation_dir(lamp["elevation_deg"], lamp["phi_deg"])
    up = np.array([0.0, 1.0, 0.0]) if abs(c[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
    e1 = _unit(np.cross(up, c))
    e2 = np.cross(c, e1)
    r = math.radians(lamp["roll_deg"])
    e1, e2 = math.cos(r) * e1 + math.sin(r) * e2, -math.sin(r) * e1 + math.cos(r) * e2
    a = math.tan(math.radians(lamp["half_width_deg"]))
    b = math.tan(math.radians(lamp["half_height_deg"]))
    dc, d1, d2 = d @ c, d @ e1, d @ e2
    return ((dc > 0) & (np.abs(d1) <= a * dc) & (np.abs(d2) <= b * dc)).astype(np.float64)


def _lamp_rows(lamps: list[dict], h: int, w: int) -> np.ndarray:
    """The rows any lamp touches (texel centres within its circumscribed cone + 2 texels)."""
    theta = np.pi * (np.arange(h) + 0.5) / h
    rows = set()
    for lamp in lamps:
        half = math.degrees(math.atan(math.hypot(math.tan(math.radians(lamp["half_width_deg"])),
                                                 math.tan(math.radians(lamp["half_height_deg"])))))
        centre = math.radians(90.0 - lamp["elevation_deg"])
        reach = math.radians(half) + 2.0 * math.pi / h
        rows |= set(np.nonzero(np.abs(theta - centre) <= reach)[0].tolist())
        if centre - reach < 0:                        # a lamp over the pole reaches every φ
            rows |= set(range(0, int(np.ceil((reach - centre) * h / np.pi)) + 1))
    return np.array(sorted(rows), int)


def lamp_map(lamps: list[dict], h: int = ENV_H, w: int = ENV_W, n: int = 8) -> np.ndarray:
    """A dim studio background LAMP_AMBIENT · (1 + 0.5 y) and the hard-edged lamps on it."""
    back = texel_means(lambda d: LAMP_AMBIENT * (1.0 + 0.5 * d[..., 1:2]) * np.ones(3), h, w, 2)
    rows = _lamp_rows(lamps, h, w)

    def lit(d):
        return sum(lamp_mask(lp, d)[..., None] * np.asarray(lp["radiance"]) for lp in lamps)
    return back + texel_means(lit, h, w, n, rows=rows)


def draw_sun(rng: np.random.Generator, *, low: bool = False) -> dict:
    """A sun: elevation 5–60° (3–15° when `low`), any azimuth, angular radius 0.27–1°, its
    irradiance (facing it) 4–20 × the sky's upper-hemisphere irradiance scale."""
    return {"elevation_deg": float(rng.uniform(3.0, 15.0) if low else rng.uniform(5.0, 60.0)),
            "phi_deg": float(rng.uniform(0.0, 360.0)),
            "radius_deg": float(rng.uniform(0.27, 1.0)),
            "irradiance": float(rng.uniform(4.0, 20.0)),
            "zenith": (np.array([0.18, 0.32, 0.75]) * rng.uniform(0.6, 1.4)).tolist(),
            "horizon": (np.array([0.85, 0.8, 0.7]) * rng.uniform(0.6, 1.4)).tolist(),
            "ground": (np.array([0.12, 0.1, 0.08]) * rng.uniform(0.5, 1.5)).tolist()}


def _sky(sun: dict, d: np.ndarray) -> np.ndarray:
    """Zenith → horizon blend ((1 − y)⁴), a glow towards the sun, a darker ground."""
    y = d[..., 1:2]
    zen, hor, gnd = (np.asarray(sun[k]) for k in ("zenith", "horizon", "ground"))
    s = elevation_dir(sun["elevation_deg"], sun["phi_deg"])
    glow = (0.5 * (1.0 + d @ s))[..., None] ** 8
    sky = (zen + (hor - zen) * (1.0 - np.clip(y, 0.0, 1.0)) ** 4) * (1.0 + 2.0 * glow)
    return np.where(y >= 0.0, sky, gnd * (1.0 + 0.3 * np.clip(y, -1.0, 0.0)))


def sky_sun_map(sun: dict, h: int = ENV_H, w: int = ENV_W) -> np.ndarray:
    """Sky gradient plus a sun disc of radiance E / (π sin² r) (E = its irradiance), the disc's
    texel coverage from 48 × 48 strata per texel near it."""
    sky = texel_means(lambda d: _sky(sun, d), h, w, 4)
    s = elevation_dir(sun["elevation_deg"], sun["phi_deg"])
    r = math.radians(sun["radius_deg"])
    radiance = sun["irradiance"] / (math.pi * math.sin(r) ** 2) * np.array([1.0, 0.93, 0.84])
    theta_s = math.radians(90.0 - sun["elevation_deg"])
    reach = r + 2.0 * math.pi / h
    rows = np.nonzero(np.abs(np.pi * (np.arange(h) + 0.5) / h - theta_s) <= reach)[0]
    cover = texel_means(lambda d: (d @ s > math.cos(r)).astype(float)[..., None] * np.ones(3),
                        h, w, 48, rows=rows)
    return sky + cover * radiance


def mixed_map(rng: np.random.Generator, h: int = ENV_H, w: int = ENV_W) -> np.ndarray:
    """One map per seed: a sky (no sun disc), 3–6 soft SG blobs (λ 20–400) and 1–2 small
    hard-edged lamps."""
    sky_params = draw_sun(rng)
    blobs = [(elevation_dir(rng.uniform(-30.0, 85.0), rng.uniform(0.0, 360.0)),
              float(10.0 ** rng.uniform(math.log10(20.0), math.log10(400.0))),
              rng.uniform(0.5, 6.0, 3)) for _ in range(int(rng.integers(3, 7)))]
    lamps = draw_lamps(rng, int(rng.integers(1, 3)))
    for lp in lamps:
        lp["half_width_deg"] *= 0.5
        lp["half_height_deg"] *= 0.5

    def soft(d):
        out = _sky(sky_params, d)
        for axis, lam, rgb in blobs:
            out = out + rgb * np.exp(lam * (d @ axis - 1.0))[..., None]
        return out
    base = texel_means(soft, h, w, 4)

    def lit(d):
        return sum(lamp_mask(lp, d)[..., None] * np.asarray(lp["radiance"]) for lp in lamps)
    return base + texel_means(lit, h, w, 8, rows=_lamp_rows(lamps, h, w))


# -- meshes --------------------------------------------------------------------------------------

def _grid_faces(rows: int, cols: int, offset: int, flip: bool) -> np.ndarray:
    """Two triangles per cell of a (rows + 1) × (cols + 1) vertex grid."""
    i, j = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    a = offset + i * (cols + 1) + j
    b, c, d = a + 1, a + cols + 1, a + cols + 2
    t = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3),
                        np.stack([b, c, d], -1).reshape(-1, 3)])
    return t[:, ::-1] if flip else t


def bowl_mesh(*, radius: float = 1.0, thickness: float = 0.15, n_phi: int = 64,
              n_theta: int = 16):
    """A thick hemispherical bowl, opening up: outer shell radius R, inner shell R − thickness,
    both about (0, R, 0) from the bottom pole (0, 0, 0) to the rim plane y = R, joined by a flat
    annular rim. Parts share no vertices (crisp creases); normals outward of the solid (the
    inner shell's towards the centre). Returns (vertices, faces, normals)."""
    phi = 2.0 * np.pi * np.arange(n_phi + 1) / n_phi
    theta = 0.5 * np.pi * np.arange(n_theta + 1) / n_theta                # from the bottom pole
    # d(θ, φ) points from the centre: θ = 0 is straight down
    d = np.stack([np.sin(theta)[:, None] * np.cos(phi)[None, :],
                  -np.cos(theta)[:, None] * np.ones_like(phi)[None, :],
                  np.sin(theta)[:, None] * np.sin(phi)[None, :]], -1).reshape(-1, 3)
    centre = np.array([0.0, radius, 0.0])
    inner_r = radius - thickness
    outer_v, inner_v = centre + radius * d, centre + inner_r * d
    ring = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], -1)
    rim_v = np.concatenate([centre + inner_r * ring, centre + radius * ring])
    v = np.concatenate([outer_v, inner_v, rim_v])
    n = np.concatenate([d, -d, np.tile([0.0, 1.0, 0.0], (len(rim_v), 1))])
    no, ni = len(outer_v), len(inner_v)
    f = np.concatenate([_grid_faces(n_theta, n_phi, 0, False),
                        _grid_faces(n_theta, n_phi, no, True),
                        _grid_faces(1, n_phi, no + ni, True)])
    f = _outward(v, f, n)
    return v, f, n


def floor_grid_mesh(*, size: float = 4.0, cells: int = 40):
    """A size × size square at y = 0 centred on the origin, cells × cells quads split in two,
    normals +Y: a floor fine enough for per-vertex transport. Returns (vertices, faces,
    normals)."""
    x = np.linspace(-0.5 * size, 0.5 * size, cells + 1)
    gx, gz = np.meshgrid(x, x, indexing="ij")
    v = np.stack([gx, np.zeros_like(gx), gz], -1).reshape(-1, 3)
    n = np.tile([0.0, 1.0, 0.0], (len(v), 1))
    return v, _outward(v, _grid_faces(cells, cells, 0, False), n), n


def _outward(v: np.ndarray, f: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Faces wound counter-clockwise seen from their vertex normals' side; degenerate pole
    triangles (zero area) dropped."""
    g = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area = np.linalg.norm(g, axis=1)
    keep = area > 1e-12
    flip = np.einsum("ij,ij->i", g, n[f].mean(axis=1)) < 0
    f = np.where(flip[:, None], f[:, ::-1], f)
    return f[keep]


# -- normal maps ---------------------------------------------------------------------------------

def vgroove_normals(size: int = 256, period: int = 8, slope_deg: float = 35.0) -> np.ndarray:
    """Symmetric v-grooves across u (ridges along v): normals (∓sin θ, 0, cos θ) on the two
    faces, period `period` texels, (size, size, 3), row 0 = v = 1."""
    cols = np.arange(size)
    t = math.radians(slope_deg)
    sx = np.where((cols % period) < period // 2, -math.sin(t), math.sin(t))
    n = np.zeros((size, size, 3))
    n[..., 0] = sx[None, :]
    n[..., 2] = math.cos(t)
    return n


def write_normal_map(path: Path, n: np.ndarray) -> Path:
    """A float EXR of (n + 1)/2 (the encoding sgpipe.normalmap.read decodes)."""
    from sgpipe.io.exr import write_exr
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_exr(path, 0.5 * (n + 1.0))
