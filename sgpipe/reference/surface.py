"""Per-sample primary hits of the `reference` method and the surface features the OpenCL methods
honour (contract: sgpipe.reference): tangent-space normal maps, kd / ks texture multipliers and
textured glTF materials (`rows["tex"]` = (kd, ks, glTF parameters (N, 5) or NaN)).

    maps = [ObjectMaps(normal_map=img, kd_map=None, ks_map=tex), ObjectMaps()]   # per object
    rows = primary_rows(tracer, camera, px, py, maps)   # px, py: image-plane positions (N,)

The conventions are those of the kernels' `pixel_init` (shading.h) and docs/CONVENTIONS.md: the
frame (n, t, b = n × t) of the G-buffer, a normal map's texel c ↦ n' = normalize(2c − 1) with
n'_z ≥ 10⁻³ in that frame, the shading frame rotated by the shortest arc taking +z to n' (the
kernels' quaternion q), visibility kept in the geometric frame; textures bilinear, OBJ uv
(v = 0 bottom row), repeat addressing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sgpipe.core.sphere import turn_frame
from sgpipe.reference import _sampling_jit as jit


@dataclass
class GltfSurface:
    """A glTF material's textured parameters (gltf_pbr): base colour = factor × texture (linear),
    roughness = factor × texture G, metallic = factor × texture B (sgpipe.io.gltf_textures)."""

    base_color: np.ndarray                  # (3,) factor
    metallic: float
    roughness: float
    base_texture: object | None = None      # GltfTexture
    metal_rough_texture: object | None = None
    anisotropy: float = 0.0                 # KHR_materials_anisotropy's strength factor
    #: its texture: RG the direction in the tangent frame (2c − 1), B × the strength
    anisotropy_texture: object | None = None

    def params(self, uv) -> np.ndarray:
        """(N, 6): base colour RGB, metallic, roughness, anisotropy strength at sgpipe UVs
        (N, 2)."""
        n = len(uv)
        out = np.empty((n, 6))
        out[:, :3] = np.asarray(self.base_color, float)
        out[:, 3], out[:, 4], out[:, 5] = self.metallic, self.roughness, self.anisotropy
        if self.anisotropy_texture is not None:
            out[:, 5] *= self.anisotropy_texture.bilinear(uv)[:, 2]
        if self.base_texture is not None:
            out[:, :3] *= self.base_texture.bilinear(uv)[:, :3]
        if self.metal_rough_texture is not None:
            mr = self.metal_rough_texture.bilinear(uv)
            out[:, 4] *= mr[:, 1]
            out[:, 3] *= mr[:, 2]
        return out

    def direction_angle(self, uv) -> np.ndarray | None:
        """(N,) the anisotropy texture's direction angle (radians, from the tangent towards the
        handed bitangent; 0 where the direction is zero), or None without the texture."""
        if self.anisotropy_texture is None:
            return None
        d = 2.0 * self.anisotropy_texture.bilinear(uv)[:, :2] - 1.0
        return np.where(np.sum(d * d, 1) > 1e-12, np.arctan2(d[:, 1], d[:, 0]), 0.0)


@dataclass
class ObjectMaps:
    """Optional per-object images (H, W, C) float: normal map (or a glTF normal texture, read
    with its sampler: sgpipe.io.gltf_textures.GltfTexture), kd and ks multipliers; and a
    textured glTF material; what the surface emits (gltf_pbr `emissive` (3,) × its emissive
    texture, a GltfTexture)."""

    normal_map: object | None = None
    kd_map: np.ndarray | None = None
    ks_map: np.ndarray | None = None
    gltf: GltfSurface | None = None
    emission: np.ndarray | None = None
    emissive_texture: object | None = None
    #: the BRDF frame turned about the shading normal (radians, from the tangent towards the
    #: bitangent of the tangent's handedness): gltf_pbr's `anisotropy_rotation`
    frame_rotation: float = 0.0

    @classmethod
    def of(cls, m) -> "ObjectMaps":
        if m is None:
            return cls()
        if isinstance(m, ObjectMaps):
            return m
        return cls(**{k: m.get(k) for k in ("normal_map", "kd_map", "ks_map", "gltf",
                                            "emission", "emissive_texture")},
                   frame_rotation=float(m.get("frame_rotation", 0.0)))

    def __post_init__(self):
        for k in ("normal_map", "kd_map", "ks_map"):
            a = getattr(self, k)
            if a is None or hasattr(a, "bilinear"):
                continue
            a = np.asarray(a, np.float64)
            if a.ndim == 2:
                a = a[:, :, None]
            if a.ndim != 3 or a.shape[0] < 1 or a.shape[1] < 1:
                raise ValueError(f"{k}: an (H, W, C) image expected, got {a.shape}")
            if a.shape[2] < 3:     # grey textures: one channel for all three (as Textures.pack)
                a = np.repeat(a[:, :, :1], 3, axis=2)
            setattr(self, k, np.ascontiguousarray(a[:, :, :3]))

    @property
    def empty(self) -> bool:
        return (self.normal_map is None and self.kd_map is None and self.ks_map is None
                and self.gltf is None and self.emission is None and self.frame_rotation == 0.0)

    def emitted(self, uv) -> np.ndarray | None:
        """(N, 3) emitted radiance at sgpipe UVs (N, 2), or None."""
        if self.emission is None:
            return None
        e = np.tile(np.asarray(self.emission, float), (len(uv), 1))
        if self.emissive_texture is not None:
            e *= self.emissive_texture.bilinear(uv)[:, :3]
        return e


def _unit(v):
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-30)


def _rotate_from_z(nl, v):
    """Rodrigues rotation of local vectors v (N, 3) by the shortest arc taking +z to unit nl."""
    x = np.stack([-nl[:, 1], nl[:, 0], np.zeros(len(nl))], -1)     # z × n'
    c = nl[:, 2]
    xv = np.einsum("ij,ij->i", x, v)
    return v * c[:, None] + np.cross(x, v) + x * (xv / np.maximum(1.0 + c, 1e-9))[:, None]


def lift(d, zmin):
    """Local directions (N, 3) raised to elevation asin(zmin) at least (the kernels' `lift`)."""
    d = np.array(d, np.float64)
    low = d[:, 2] < zmin
    if low.any():
        xy = d[low, :2]
        ln = np.linalg.norm(xy, axis=1, keepdims=True)
        xy = np.where(ln > 1e-8, xy / np.maximum(ln, 1e-30), [[1.0, 0.0]])
        d[low, :2] = xy * np.sqrt(1.0 - zmin * zmin)
        d[low, 2] = zmin
    return d


def _local(v, t, b, n):
    return np.stack([np.einsum("ij,ij->i", v, t), np.einsum("ij,ij->i", v, b),
                     np.einsum("ij,ij->i", v, n)], -1)


def mapped_view(view, t, b, n, t2, b2, n2):
    """The view direction the kernels shade a normal-mapped pixel with: lifted to elevation
    ≥ asin 0.01 in the G-buffer frame (t, b, n), then again in the mapped frame (t2, b2, n2)
    (pixel_init: a mapped normal facing away from the viewer keeps a grazing view instead of
    turning the pixel black). World vectors (N, 3)."""
    ol = lift(_local(view, t, b, n), 0.01)
    ow = ol[:, :1] * t + ol[:, 1:2] * b + ol[:, 2:3] * n
    op = lift(_unit(_local(ow, t2, b2, n2)), 0.01)
    return op[:, :1] * t2 + op[:, 1:2] * b2 + op[:, 2:3] * n2


def normal_mapped_frame(t, b, n, texel):
    """Frames (t', b', n') of the normal map's texels (N, 3) in the frames (t, b, n)."""
    nl = 2.0 * np.asarray(texel, np.float64) - 1.0
    nl[:, 2] = np.maximum(nl[:, 2], 1e-3)
    nl = _unit(nl)
    ex = np.zeros_like(nl)
    ex[:, 0] = 1.0
    ey = np.zeros_like(nl)
    ey[:, 1] = 1.0
    world = lambda v: v[:, :1] * t + v[:, 1:2] * b + v[:, 2:3] * n  # noqa: E731
    return (_unit(world(_rotate_from_z(nl, ex))), _unit(world(_rotate_from_z(nl, ey))),
            _unit(world(nl)))


def primary_rows(tracer, camera, px, py, maps=None, backfacing: str = "lift") -> dict:
    """Trace rays through image-plane positions (px, py) (N,) → per row: `hit`, `dirs`, and for
    the hit rows (index `idx`) the shading inputs `pos`, `t`, `b`, `n` (normal-mapped frame),
    `ng`, `view`, `obj`, `tex` ((kd scale, ks scale) (M, 3) each, or None) and `emit` (what
    the surface emits (M, 3), or None). `backfacing`:
    where the view lies behind a mapped normal, "lift" shades it at a grazing view as the
    kernels do (mapped_view); "black" reflects nothing there (Mitsuba 3's `normalmap`)."""
    o, d = camera.rays_at(px, py)
    d64 = np.asarray(d, np.float64)
    if tracer is None:
        return {"hit": np.zeros(len(d64), bool), "dirs": d64, "idx": np.zeros(0, np.int64)}
    gb = tracer.trace(o, d)
    idx = np.flatnonzero(gb.hit)
    g = lambda a: np.asarray(a[idx], np.float64)  # noqa: E731
    pos, n, t, ng, view = (g(gb.position), g(gb.normal), g(gb.tangent), g(gb.geo_normal),
                           g(gb.view))
    obj = gb.object_id[idx].astype(np.int64)
    hand = None if gb.handedness is None else np.asarray(gb.handedness[idx])
    # CONVENTIONS frame: t ⟂ n, b = n × t (the G-buffer's float32 values re-orthonormalised)
    n = _unit(n)
    t = _unit(t - np.einsum("ij,ij->i", t, n)[:, None] * n)
    b = np.cross(n, t)
    tex = emit = None
    maps = [ObjectMaps.of(m) for m in (maps or ())]
    if any(not m.empty for m in maps):
        uv = np.asarray(gb.uv[idx], np.float64)
        kd = np.ones((len(idx), 3))
        ks = np.ones((len(idx), 3))
        sv = np.full((len(idx), 6), np.nan)     # glTF textured parameters (NaN: none)
        scaled = any(m.kd_map is not None or m.ks_map is not None or m.gltf is not None
                     for m in maps)
        for k, m in enumerate(maps):
            sel = np.flatnonzero(obj == k)
            if m.empty or sel.size == 0:
                continue
            if m.gltf is not None:
                sv[sel] = m.gltf.params(uv[sel])
            if m.emission is not None:
                if emit is None:
                    emit = np.zeros((len(idx), 3))
                emit[sel] = m.emitted(uv[sel])
            if m.kd_map is not None:
                kd[sel] = jit.tex_bilinear(m.kd_map, uv[sel])
            if m.ks_map is not None:
                ks[sel] = jit.tex_bilinear(m.ks_map, uv[sel])
            if m.normal_map is not None:
                texel = (m.normal_map.bilinear(uv[sel])[:, :3].copy()
                         if hasattr(m.normal_map, "bilinear")
                         else jit.tex_bilinear(m.normal_map, uv[sel]))
                if hand is not None:     # +Y along w (n × t): the kernels' gtan.w flip
                    flip = hand[sel] < 0
                    texel[flip, 1] = 1.0 - texel[flip, 1]
                t2, b2, n2 = normal_mapped_frame(t[sel], b[sel], n[sel], texel)
                if backfacing == "black":   # the BRDF's scales zeroed: no light, no bounce
                    behind = sel[np.einsum("ij,ij->i", view[sel], n2) <= 0.0]
                    kd[behind] = 0.0
                    ks[behind] = 0.0
                    scaled = scaled or behind.size > 0
                view[sel] = mapped_view(view[sel], t[sel], b[sel], n[sel], t2, b2, n2)
                t[sel], b[sel], n[sel] = t2, b2, n2
            angle = m.gltf.direction_angle(uv[sel]) if m.gltf is not None else None
            if m.frame_rotation != 0.0 or angle is not None:
                # towards w · n × t, as the kernels' pixel_init
                turn = np.full(sel.size, m.frame_rotation) + (0.0 if angle is None else angle)
                if hand is not None:
                    turn[hand[sel] < 0] *= -1.0
                t[sel], b[sel] = turn_frame(t[sel], b[sel], turn)
        if scaled:
            tex = (kd, ks, sv)
    return {"hit": gb.hit, "dirs": d64, "idx": idx, "pos": pos, "t": t, "b": b, "n": n,
            "ng": ng, "view": view, "obj": obj, "tex": tex, "emit": emit}
