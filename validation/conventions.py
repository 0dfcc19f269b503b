"""sgpipe's conventions (docs/CONVENTIONS.md) mapped onto Mitsuba 3's, in plain numpy.

Nothing here imports Mitsuba: the functions return the numbers a Mitsuba scene dict needs and
reproduce, in numpy, the rules Mitsuba 3.9 applies to them (its perspective sensor, its `envmap`
lookup), so tests can check the mapping without Mitsuba and, where it is installed, check the
numpy replicas against Mitsuba itself (tests/validation/).
"""

from __future__ import annotations

import math

import numpy as np

# --- camera ----------------------------------------------------------------------------------


def look_at_matrix(eye, target, up) -> np.ndarray:
    """Mitsuba's `Transform4f.look_at`: columns (left, up', dir, eye) with dir = target − eye,
    left = up × dir, up' = dir × left (camera space: +Z forward, +X left, +Y up)."""
    eye = np.asarray(eye, float)
    d = np.asarray(target, float) - eye
    d /= np.linalg.norm(d)
    left = np.cross(np.asarray(up, float), d)
    left /= np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, eye
    return m


def sensor_params(camera) -> dict:
    """The Mitsuba `perspective` sensor of an sgpipe camera (CameraSpec or Camera): sgpipe's
    fov is vertical (fov_axis y), pixel (0, 0) top-left in both, same right-handed basis."""
    return {"fov": float(camera.fov_deg), "fov_axis": "y",
            "to_world": look_at_matrix(camera.eye, camera.target, camera.up),
            "width": int(camera.width), "height": int(camera.height)}


def mitsuba_ray_directions(params: dict, film_xy: np.ndarray) -> np.ndarray:
    """World directions Mitsuba's perspective sensor gives film positions (..., 2) in [0, 1]²
    (x right, y down), as its camera_to_sample transform defines them: camera-space
    (−(2x − 1) tan(fov_x/2), −(2y − 1) tan(fov_x/2)/aspect, 1), aspect = width/height."""
    aspect = params["width"] / params["height"]
    t = math.tan(math.radians(params["fov"]) / 2)
    tx = t * aspect if params["fov_axis"] == "y" else t
    xy = np.asarray(film_xy, float)
    local = np.stack([-(2 * xy[..., 0] - 1) * tx, -(2 * xy[..., 1] - 1) * tx / aspect,
                      np.ones(xy.shape[:-1])], -1)
    d = local @ params["to_world"][:3, :3].T
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def pixel_centres(width: int, height: int) -> np.ndarray:
    """Film positions (H, W, 2) of the pixel centres: sgpipe's (ox, oy) = (½, ½)."""
    x = (np.arange(width) + 0.5) / width
    y = (np.arange(height) + 0.5) / height
    return np.stack(np.broadcast_arrays(x[None, :], y[:, None]), -1)


def rfilter_dict(pixel_filter) -> dict:
    """Mitsuba's reconstruction filter of sgpipe's `render.pixel_filter` (type, radius, stddev):
    box (the pixel) → box; tent radius r → tent(radius r); gaussian σ (radius 4σ) →
    gaussian(stddev σ), Mitsuba's own truncated, shifted Gaussian. sgpipe draws each sample's
    sub-pixel offset from the filter, Mitsuba splats uniform samples with the filter's weights:
    both converge to ∫ f L / ∫ f."""
    get = pixel_filter.get if isinstance(pixel_filter, dict) else \
        (lambda k, d=None: getattr(pixel_filter, k, d))
    kind, radius = get("type", "box"), get("radius", None)
    if kind == "box" and radius in (None, 0.5):
        return {"type": "box"}
    if kind == "tent":
        return {"type": "tent", "radius": float(radius if radius is not None else 1.0)}
    if kind == "gaussian":
        sd = float(get("stddev", 0.5))
        if radius is None or abs(radius - 4 * sd) < 1e-9:
            return {"type": "gaussian", "stddev": sd}
    raise Unmappable(f"pixel filter {kind!r} (radius {radius}) has no Mitsuba rfilter "
                     "counterpart")


# --- environment map -------------------------------------------------------------------------

#: sgpipe's lat-long directions and Mitsuba's envmap share φ = atan2(x, −z), θ = acos(y).
ENVMAP_TO_WORLD = np.eye(4)


def envmap_to_world(rotation=None) -> np.ndarray:
    """The envmap emitter's to_world (4, 4) for sgpipe's render.environment_rotation R (world ←
    map, 3×3; None: ENVMAP_TO_WORLD): Mitsuba looks the map up at to_world⁻¹·ω = Rᵀω, as
    sgpipe's lookups do."""
    m = np.array(ENVMAP_TO_WORLD, float)
    if rotation is not None:
        r4 = np.eye(4)
        r4[:3, :3] = np.asarray(rotation, float)
        m = r4 @ m
    return m


def mitsuba_envmap_uv(dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) Mitsuba's envmap looks up for world directions (to_world = identity):
    u = atan2(x, −z)/2π mod 1, v = acos(y)/π."""
    d = np.asarray(dirs, float)
    u = np.mod(np.arctan2(d[..., 0], -d[..., 2]) / (2 * np.pi), 1.0)
    v = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi
    return u, v


def mitsuba_envmap_eval(data: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Radiance Mitsuba 3.9's envmap returns for a lat-long bitmap (H, W, 3): bilinear, columns
    texel-centred and periodic (u = (j + ½)/W at column j), rows **vertex-centred** (row r at
    v = r/(H − 1): row 0 is exactly the pole)."""
    h, w = data.shape[:2]
    u, v = mitsuba_envmap_uv(dirs)
    x = u * w - 0.5
    y = v * (h - 1)
    x0 = np.floor(x).astype(int)
    y0 = np.clip(np.floor(y).astype(int), 0, max(h - 2, 0))
    fx, fy = (x - x0)[..., None], np.clip(y - y0, 0, 1)[..., None]
    xa, xb = np.mod(x0, w), np.mod(x0 + 1, w)
    y1 = np.minimum(y0 + 1, h - 1)
    top = data[y0, xa] * (1 - fx) + data[y0, xb] * fx
    bot = data[y1, xa] * (1 - fx) + data[y1, xb] * fx
    return top * (1 - fy) + bot * fy


def sgpipe_envmap_eval(latlong: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """sgpipe's piecewise-constant lookup (the reference's `lookup_env`): the texel containing
    the direction, texel (i, j) covering θ ∈ [πi/H, π(i+1)/H], φ ∈ [2πj/W, 2π(j+1)/W]."""
    h, w = latlong.shape[:2]
    u, v = mitsuba_envmap_uv(dirs)
    j = np.clip((u * w).astype(int), 0, w - 1)
    i = np.clip((v * h).astype(int), 0, h - 1)
    return latlong[i, j]


def envmap_for_mitsuba(latlong: np.ndarray, factor: int = 4,
                       factor_v: int | None = None) -> np.ndarray:
    """A bitmap on which Mitsuba's bilinear, row-vertex-centred lookup reproduces sgpipe's
    piecewise-constant map: each texel repeated `factor`× in u (texel-centred columns: the
    linear ramp between two copies is centred on the texel edge, so every φ-integral is exact;
    an edge is blurred by ±1/(2·factor) texel) and, in v, `factor_v`·H rows (default `factor`)
    at Mitsuba's v_r = r/(factor_v·H − 1), each the hat-weighted mean of the map over
    [v_{r−1}, v_{r+1}] (weight hat × sin θ): the ramps stay centred on the row edges, which are
    blurred by ±2/factor_v texel. Nearest-row values would put each ramp up to 1/(2·factor_v)
    texel off the edge, always towards the pole (on data_samples/studio.exr at 4: −0.03 /
    −0.09 / −0.07 % of the irradiance at +Y; hat means: +0.001 %). Values more than two
    resampled rows from a row edge are exact."""
    h, w = latlong.shape[:2]
    kv = int(factor_v or factor)
    cols = np.repeat(np.asarray(latlong, np.float64), factor, axis=1)
    return np.ascontiguousarray(np.tensordot(_row_weights(h, kv * h), cols, axes=(1, 0)),
                                np.float32)


def _row_weights(h: int, hh: int, sub: int = 64) -> np.ndarray:
    """(hh, h): weight of sgpipe row i in Mitsuba row r, ∫ hat_r(v) sin(πv) 1_i(v) dv
    normalised per r (midpoint rule, `sub` points per resampled row interval)."""
    dv = 1.0 / (hh - 1)
    t = (np.arange(sub) + 0.5) / sub                        # within one interval
    out = np.zeros((hh, h))
    for r in range(hh):
        for side in (-1, 1):
            lo = r if side > 0 else r - 1
            if lo < 0 or lo >= hh - 1:
                continue
            v = (lo + t) * dv
            hat = 1.0 - np.abs(v - r * dv) / dv
            wgt = hat * np.sin(np.pi * v)
            rows = np.minimum((v * h).astype(int), h - 1)
            np.add.at(out[r], rows, wgt)
        tot = out[r].sum()
        if tot > 0:
            out[r] /= tot
        else:                                               # never: hats reach inside
            out[r, min(int(r * dv * h), h - 1)] = 1.0
    return out


# --- shapes ----------------------------------------------------------------------------------


def rotation_x(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    m = np.eye(4)
    m[1:3, 1:3] = [[c, -s], [s, c]]
    return m


def sphere_to_world(center, radius) -> np.ndarray:
    """to_world of a Mitsuba `sphere` whose shading tangent is sgpipe's: Mitsuba's sphere has
    ∂p/∂u = ẑ_local × p (azimuth about its local +Z); sgpipe's tangent is n × ŷ, the azimuth
    about world +Y taken the other way, so local +Z must map to world −Y (a +90° turn about X)."""
    t = np.eye(4)
    t[:3, 3] = np.asarray(center, float)
    s = np.diag([radius, radius, radius, 1.0])
    return t @ rotation_x(90.0) @ s


def mitsuba_sphere_tangent(to_world: np.ndarray, p_world: np.ndarray) -> np.ndarray:
    """Unit ∂p/∂u of Mitsuba's sphere at world points (its local rule (−y, x, 0))."""
    inv = np.linalg.inv(to_world)
    p = np.asarray(p_world, float) @ inv[:3, :3].T + inv[:3, 3]
    local = np.stack([-p[..., 1], p[..., 0], np.zeros(p.shape[:-1])], -1)
    t = local @ to_world[:3, :3].T
    return t / np.linalg.norm(t, axis=-1, keepdims=True)


# --- materials and lights --------------------------------------------------------------------


class Unmappable(ValueError):
    """An sgpipe material feature without an exact Mitsuba counterpart."""


def _rgb(v):
    return [float(x) for x in np.broadcast_to(np.asarray(v, float), (3,))]


def bsdf_dict(brdf) -> dict:
    """Mitsuba BSDF dict of an sgpipe BRDF (sgpipe.brdf), two-sided like sgpipe's surfaces.

    lambert kd → diffuse(kd); beckmann / ggx (ks, α or α_u/α_v, fresnel none or conductor) →
    roughconductor(distribution, alpha_u, alpha_v, specular_reflectance = ks, material none or
    eta/k): both are ks F D G1(i) G1(o) / (4 cos cos) with D the normalised NDF. With kd > 0
    sgpipe adds kd/π: blendbsdf(weight w) = (1−w)·diffuse(kd/(1−w)) + w·roughconductor(ks/w).
    Schlick / dielectric Fresnel, Ward, Cook–Torrance, Blinn–Phong, Ashikhmin–Shirley and
    measured BRDFs have no exact Mitsuba counterpart: Unmappable.
    """
    name = brdf.name
    if name == "lambert":
        inner = {"type": "diffuse", "reflectance": {"type": "rgb", "value": _rgb(brdf.kd)}}
        return {"type": "twosided", "bsdf": inner}
    if name not in ("beckmann", "ggx"):
        raise Unmappable(f"BRDF model {name!r} has no exact Mitsuba counterpart")
    fr = brdf.fresnel
    spec = {"type": "roughconductor", "distribution": name,
            "alpha_u": float(brdf.shadowing.au), "alpha_v": float(brdf.shadowing.av),
            "sample_visible": True}
    if fr.kind == "none":
        spec["material"] = "none"
    elif fr.kind == "conductor":
        spec["eta"] = {"type": "rgb", "value": _rgb(fr.eta)}
        spec["k"] = {"type": "rgb", "value": _rgb(fr.k)}
    else:
        raise Unmappable(f"fresnel {fr.kind!r} has no exact Mitsuba roughconductor counterpart "
                         "(use fresnel: none or conductor)")
    ks, kd = np.asarray(brdf.ks, float), np.asarray(brdf.kd, float)
    if brdf.diffuse_kind == "none":
        spec["specular_reflectance"] = {"type": "rgb", "value": _rgb(ks)}
        return {"type": "twosided", "bsdf": spec}
    if brdf.diffuse_kind != "lambert":
        raise Unmappable(f"diffuse term {brdf.diffuse_kind!r} has no Mitsuba counterpart")
    w = blend_weight(kd, ks)
    spec["specular_reflectance"] = {"type": "rgb", "value": _rgb(ks / w)}
    diffuse = {"type": "diffuse", "reflectance": {"type": "rgb", "value": _rgb(kd / (1 - w))}}
    return {"type": "twosided",
            "bsdf": {"type": "blendbsdf", "weight": w,
                     "bsdf_0": diffuse, "bsdf_1": spec}}


def blend_weight(kd, ks) -> float:
    """blendbsdf weight w of the specular part: its share of the total albedo bound, so both
    rescaled parts (kd/(1−w), ks/w) stay ≤ max(kd) + max(ks)."""
    a, b = float(np.max(kd)), float(np.max(ks))
    return min(max(b / (a + b), 0.05), 0.95) if a + b > 0 else 0.5


def emitter_dict(light) -> dict:
    """Mitsuba emitter of an sgpipe light (LightSpec): point → point (intensity in W/sr, the
    reference's delta light; sgpipe's `radius` only shapes the SG methods' lobe), directional →
    directional (irradiance E on a surface facing it; Mitsuba's direction points away from the
    light, sgpipe's towards it)."""
    if light.type == "point":
        return {"type": "point", "position": [float(x) for x in light.position],
                "intensity": {"type": "rgb", "value": _rgb(light.intensity)}}
    d = np.asarray(light.direction, float)
    d = d / np.linalg.norm(d)
    return {"type": "directional", "direction": [float(-x) for x in d],
            "irradiance": {"type": "rgb", "value": _rgb(light.intensity)}}
