"""kd / ks textures and tangent-space normal maps mapped onto Mitsuba 3, in plain numpy.

sgpipe (sgpipe.reference.surface, the kernels' tex_bilinear): textures bilinear, texel centres
at half-integers, OBJ uv with v = 0 the **bottom** row, repeat addressing; a normal map's texel
c ↦ n' = normalize(2c − 1) (n'_z ≥ 10⁻³) in the frame (t, b = n × t, n), t the per-vertex
tangent ∂p/∂u interpolated and made ⟂ n. Mitsuba 3.9 (probed, tests/validation/): `bitmap`
textures bilinear with texel centres at half-integers, v = 0 the **top** row (row y = v·H − ½),
`wrap_mode` repeat; `normalmap` takes n = 2c − 1 in the shading frame (s, t = n × s, n) with s
the per-**triangle** ∂p/∂u made ⟂ n. Data here; mi.Bitmap objects are made in
validation.mitsuba_scene (`bitmap` dicts carry the array under "data").
"""

from __future__ import annotations

import numpy as np

from validation.conventions import Unmappable


def bitmap_for_mitsuba(img) -> np.ndarray:
    """sgpipe texture (H, W, C) → the array Mitsuba's bitmap must hold for the same lookup at
    the same uv: rows reversed (Mitsuba's row 0 is v = 0, sgpipe's is v = 1)."""
    return np.ascontiguousarray(np.asarray(img, np.float32)[::-1])


def mitsuba_bitmap_eval(data, uv) -> np.ndarray:
    """Mitsuba's bilinear, repeat-addressed `bitmap` lookup (N, C) at uv (N, 2): texel (r, c)
    centred at u = (c + ½)/W, v = (r + ½)/H (row 0 at v = 0)."""
    data = np.asarray(data, np.float64)
    h, w = data.shape[:2]
    uv = np.asarray(uv, np.float64)
    x, y = uv[:, 0] * w - 0.5, uv[:, 1] * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    xa, ya = np.mod(x0.astype(int), w), np.mod(y0.astype(int), h)
    xb, yb = np.mod(xa + 1, w), np.mod(ya + 1, h)
    top = data[ya, xa] * (1 - fx) + data[ya, xb] * fx
    bot = data[yb, xa] * (1 - fx) + data[yb, xb] * fx
    return top * (1 - fy) + bot * fy


def bitmap_dict(data) -> dict:
    """A Mitsuba `bitmap` texture of raw linear data (no sRGB decoding), bilinear, repeat."""
    return {"type": "bitmap", "data": np.asarray(data, np.float32), "raw": True,
            "filter_type": "bilinear", "wrap_mode": "repeat"}


def _scaled_map(img, rgb) -> np.ndarray:
    """bitmap_for_mitsuba(img) × the constant the mapped BSDF holds (bilinear is linear, so the
    product of the interpolated texture and the constant is the interpolated product)."""
    return bitmap_for_mitsuba(np.asarray(img, np.float64)[..., :3] * np.asarray(rgb, np.float64))


def textured_bsdf_dict(d: dict, kd_map=None, ks_map=None) -> dict:
    """conventions.bsdf_dict's dict with sgpipe's kd / ks texture multipliers (sgpipe: ρ =
    kd_map·diffuse + ks_map·specular): every `diffuse` reflectance × kd_map, every
    `roughconductor` specular_reflectance × ks_map, as bitmap textures."""
    if kd_map is None and ks_map is None:
        return d
    seen = {"diffuse": False, "roughconductor": False}

    def walk(node):
        if not isinstance(node, dict):
            return node
        out = {k: walk(v) for k, v in node.items()}
        kind = node.get("type")
        if kind == "diffuse" and kd_map is not None:
            out["reflectance"] = bitmap_dict(_scaled_map(kd_map, node["reflectance"]["value"]))
            seen["diffuse"] = True
        if kind == "roughconductor" and ks_map is not None:
            out["specular_reflectance"] = bitmap_dict(
                _scaled_map(ks_map, node["specular_reflectance"]["value"]))
            seen["roughconductor"] = True
        return out
    out = walk(d)
    if kd_map is not None and not seen["diffuse"]:
        raise Unmappable("kd_map on a material without a diffuse term")
    if ks_map is not None and not seen["roughconductor"]:
        raise Unmappable("ks_map on a material without a specular lobe")
    return out


def normalmap_bsdf_dict(d: dict, normal_map) -> dict:
    """Mitsuba's `normalmap` BSDF around the (two-sided) mapped BSDF, its texture the normal
    map's raw texels (rows reversed): n = 2c − 1 in the shading frame, as sgpipe decodes it.
    Mitsuba 3.9's two defaults that sgpipe has no counterpart of are off: use_shadowing_function
    (Estevez 2019's terminator factor ≤ 1 on every light: −0.3 % on the bump map, −1.8 % at
    some pixels) and flip_invalid_normals (n' mirrored to (−x, −y, z) where the view is behind
    it; sgpipe lifts the view instead, Mitsuba then returns 0: docs/VALIDATION.md)."""
    inner = d["bsdf"] if d.get("type") == "twosided" else d
    return {"type": "twosided",
            "bsdf": {"type": "normalmap", "flip_invalid_normals": False,
                     "use_shadowing_function": False,
                     "normalmap": bitmap_dict(bitmap_for_mitsuba(
                         np.asarray(normal_map, np.float64)[..., :3])), "bsdf": inner}}


def check_mappable(spec, *, has_uvs: bool, textured: bool, backfacing: str = "black") -> None:
    """Refuse texture / normal-map features whose uv or tangent frame Mitsuba does not share:
    analytic spheres (Mitsuba's sphere has its own uv) and meshes without UVs (sgpipe then
    reads uv (0, 0) and takes the azimuthal tangent); and normal maps unless the reference
    reflects nothing where the view is behind the mapped normal
    (`render.reference_mapped_backfacing: black`), which is what Mitsuba's `normalmap` does."""
    if not (textured or spec.normal_map is not None):
        return
    if spec.normal_map is not None and backfacing != "black":
        raise Unmappable(f"object {spec.name!r}: normal map with render.reference_mapped_"
                         f"backfacing {backfacing!r}; Mitsuba's normalmap reflects nothing where "
                         "the view is behind the mapped normal: set it to black")
    if spec.sphere_radius is not None:
        raise Unmappable(f"object {spec.name!r}: textures / normal maps on an analytic sphere "
                         "(Mitsuba's sphere has other uv; use data_samples/sphere.obj)")
    if not has_uvs:
        raise Unmappable(f"object {spec.name!r}: textures / normal maps on a mesh without uv")


# --- tangent frames --------------------------------------------------------------------------


def triangle_dp_du(positions, faces, uvs) -> np.ndarray:
    """Per-triangle ∂p/∂u (F, 3) of the linear uv parameterisation (Mitsuba's si.dp_du)."""
    p, t = np.asarray(positions, np.float64)[faces], np.asarray(uvs, np.float64)[faces]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    return (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / det[:, None]


def _gram_schmidt(t, n):
    t = t - np.sum(t * n, axis=-1, keepdims=True) * n
    return t / np.linalg.norm(t, axis=-1, keepdims=True)


def mapped_normals(texel, t, n) -> np.ndarray:
    """World normals (N, 3) both renderers give texels (N, 3) in the frame (t, n × t, n), t
    made ⟂ n (sgpipe's n'_z ≥ 10⁻³ clamp aside: never reached on the sample maps)."""
    t = _gram_schmidt(np.asarray(t, np.float64), n)
    nl = 2.0 * np.asarray(texel, np.float64) - 1.0
    w = nl[:, :1] * t + nl[:, 1:2] * np.cross(n, t) + nl[:, 2:3] * n
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def frame_difference_deg(positions, faces, uvs, vertex_tangents, vertex_normals, texel,
                         samples: int = 20000, seed: int = 0) -> dict:
    """Angles (degrees) between the mapped normals of sgpipe's frame (interpolated per-vertex
    tangents) and Mitsuba's (per-triangle ∂p/∂u), both ⟂ the interpolated normal, at random
    points of random triangles, for one constant texel: {"tangent": (p50, max), "normal":
    (p50, max)}."""
    rng = np.random.default_rng(seed)
    faces = np.asarray(faces)
    tri = rng.integers(0, len(faces), samples)
    b = rng.dirichlet(np.ones(3), samples)
    lerp = lambda a: np.einsum("ij,ijk->ik", b, np.asarray(a, np.float64)[faces[tri]])  # noqa
    n = lerp(vertex_normals)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    ts = _gram_schmidt(lerp(vertex_tangents), n)
    tm = _gram_schmidt(triangle_dp_du(positions, faces, uvs)[tri], n)
    tex = np.broadcast_to(np.asarray(texel, np.float64), (samples, 3))
    ang = lambda a, c: np.degrees(np.arccos(np.clip(np.sum(a * c, 1), -1, 1)))  # noqa: E731
    dt = ang(ts, tm)
    dn = ang(mapped_normals(tex, ts, n), mapped_normals(tex, tm, n))
    return {"tangent": (float(np.median(dt)), float(dt.max())),
            "normal": (float(np.median(dn)), float(dn.max()))}
