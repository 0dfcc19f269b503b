"""Local lights of the `reference` method (contract: sgpipe.reference): delta point /
directional lights evaluated exactly, or — for `area_lights` and a light `radius` r > 0, the size
the SG methods give the light (Wang09 eq 32–33) — lights of uniform radiance sampled uniformly in
the cone they subtend:

* point light of intensity I and radius r: a sphere of radiance L = I/(πr²) (its intensity is I
  in every direction); seen from distance d it fills the cone sin α = r/d;
* directional light of irradiance E and radius r = tan α: a disc of angular radius α and
  radiance L = E/(π sin²α) (irradiance E on a surface facing it).

Uniform cone sampling has pdf 1/(2π(1 − cos α)), so each sample weighs L·2π(1 − cos α), i.e.
2I/(d²(1 + cos α)) and 2E/(1 + cos α): both tend to the delta light's I/d² and E as r → 0, and a
Lambert receiver that sees the whole light gets exactly the delta light's radiance (the
projected solid angle of a cone fully above the horizon is π sin²α cos β).
"""

from __future__ import annotations

import numpy as np


def _get(obj, *names, default=None):
    for n in names:
        v = obj.get(n) if isinstance(obj, dict) else getattr(obj, n, None)
        if v is not None:
            return v
    return default


def _rgb(v):
    a = np.asarray(v, np.float64).reshape(-1)
    return np.repeat(a, 3) if a.size == 1 else a[:3]


def normalize_lights(lights, area_lights: bool = False) -> list[tuple]:
    """Lights → [(kind, unit dir to light | position, E | I rgb, radius)], kind "directional" or
    "point"; the radius is 0 (a delta light) unless `area_lights`."""
    out = []
    for L in lights or ():
        kind = str(_get(L, "type", "kind", default="directional")).lower()
        r = float(_get(L, "radius", default=0.0)) if area_lights else 0.0
        if r < 0 or not np.isfinite(r):
            raise ValueError(f"light radius must be >= 0, got {r}")
        if kind in ("directional", "distant", "sun"):
            d = np.asarray(_get(L, "direction", "vector"), np.float64)
            d = d / np.linalg.norm(d)
            e = _rgb(_get(L, "irradiance", "intensity", "color", "radiance", default=1.0))
            out.append(("directional", d, e, r))
        elif kind == "point":
            p = np.asarray(_get(L, "position", "vector"), np.float64)
            out.append(("point", p, _rgb(_get(L, "intensity", "color", default=1.0)), r))
        else:
            raise ValueError(f"unknown light type {kind!r}")
    return out


def _cone_dirs(axis, one_minus_cos, u1, u2):
    """Uniform directions in the cones about unit `axis` (N, 3) with 1 − cos α (N,)."""
    om = u1 * one_minus_cos                                   # 1 − cos θ, without cancellation
    cos_t = 1.0 - om
    sin_t = np.sqrt(np.maximum(om * (2.0 - om), 0.0))
    phi = 2.0 * np.pi * u2
    # orthonormal basis about the axis (Duff et al. 2017)
    x, y, z = axis[:, 0], axis[:, 1], axis[:, 2]
    sgn = np.where(z >= 0, 1.0, -1.0)
    a = -1.0 / (sgn + z)
    bb = x * y * a
    e1 = np.stack([1.0 + sgn * x * x * a, sgn * bb, -sgn * x], -1)
    e2 = np.stack([bb, sgn + y * y * a, -y], -1)
    d = ((sin_t * np.cos(phi))[:, None] * e1 + (sin_t * np.sin(phi))[:, None] * e2
         + cos_t[:, None] * axis)
    return d / np.linalg.norm(d, axis=1, keepdims=True), cos_t


def light_samples(light, pos, u1=None, u2=None):
    """Per shading point (N, 3): direction to the light (N, 3), the RGB factor (N, 3) that
    multiplies f·cos θ·V (radiance / pdf, or the delta light's E, I/d²), and the shadow ray's
    tmax (N,) (inf for directional lights)."""
    kind, v, e, r = light
    n = len(pos)
    if kind == "directional":
        axis = np.broadcast_to(v, pos.shape)
        if r <= 0:
            return np.ascontiguousarray(axis), np.broadcast_to(e, (n, 3)), np.full(n, np.inf)
        s2 = r * r / (1.0 + r * r)                            # sin²α, tan α = r
        cos_max = np.sqrt(1.0 - s2)
        d, _ = _cone_dirs(np.ascontiguousarray(axis), np.full(n, s2 / (1.0 + cos_max)), u1, u2)
        return d, np.broadcast_to(2.0 * e / (1.0 + cos_max), (n, 3)), np.full(n, np.inf)
    to = v - pos
    dist = np.linalg.norm(to, axis=1)
    axis = to / np.maximum(dist, 1e-30)[:, None]
    delta = (r <= 0) | (dist <= r * (1.0 + 1e-9))             # inside the sphere: as a point
    if np.all(delta):
        return axis, e[None, :] / np.maximum(dist, 1e-30)[:, None] ** 2, dist
    s2 = np.where(delta, 0.0, (r / np.maximum(dist, 1e-30)) ** 2)
    cos_max = np.sqrt(1.0 - s2)
    d, cos_t = _cone_dirs(axis, s2 / (1.0 + cos_max), u1, u2)
    d = np.where(delta[:, None], axis, d)
    factor = np.where(delta[:, None], e[None, :] / np.maximum(dist, 1e-30)[:, None] ** 2,
                      2.0 * e[None, :] / (dist * dist * (1.0 + cos_max))[:, None])
    # the near side of the sphere along d: d·cos θ − √(r² − d² sin² θ)
    t_hit = dist * cos_t - np.sqrt(np.maximum(r * r - dist * dist * (1.0 - cos_t * cos_t), 0.0))
    return d, factor, np.where(delta, dist, t_hit)
