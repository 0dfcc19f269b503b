"""Primary visibility: Embree (embreex) for meshes + analytic ray–sphere → a G-buffer.

    objs = [TraceObject.mesh("teapot", V, F, normals=N, uvs=UV),
            TraceObject.sphere("ball", center=(0, 1, 0), radius=0.5)]
    origins, dirs = camera.rays()
    gb = trace_gbuffer(objs, origins, dirs)          # any leading shape, here (H, W)
    gb.normal[gb.hit], gb.object_id, gb.triangle_id, gb.barycentrics ...
    coeffs = gb.interpolate([per_vertex_teapot, None])   # per-pixel per-vertex attributes

    tracer = Tracer(objs)                             # reusable (e.g. for shadow rays)
    blocked = tracer.occluded(points, dirs, tmax=np.inf, tnear=1e-4)

Conventions (docs/CONVENTIONS.md): shading frame (n, t, b = n × t); a mesh's tangent is its per-vertex
tangent when given, else the azimuthal rule of `sgpipe.core.sphere.tangent_frame`; an analytic
sphere has lat-long UVs of its object-space normal (u = φ/2π, v = 1 − θ/π as
data_samples/sphere.obj: OBJ v = 0 is the image's bottom row) and the world
azimuthal tangent. Surfaces are two-sided: when the ray meets the back of a triangle, the geometric
and shading normals are flipped towards the viewer (`backface` records it).
Barycentrics follow Embree: P = (1 − b0 − b1)·V0 + b0·V1 + b1·V2; triangle_id = −1 on spheres.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sgpipe.core.sphere import tangent_frame


@dataclass
class TraceObject:
    """One traceable object in world space: a triangle mesh or an analytic sphere."""

    name: str
    kind: str  # "mesh" | "sphere"
    vertices: np.ndarray | None = None   # (V, 3) world positions
    faces: np.ndarray | None = None      # (F, 3) int vertex indices
    normals: np.ndarray | None = None    # (V, 3) per-vertex shading normals (optional)
    tangents: np.ndarray | None = None   # (V, 3) per-vertex tangents (optional)
    uvs: np.ndarray | None = None        # (V, 2) texture coordinates (optional)
    center: np.ndarray | None = None     # (3,) sphere centre
    radius: float = 0.0                  # sphere radius
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))  # sphere object→world
    handedness: np.ndarray | None = None  # (V,) ±1: normal-map +Y along ± n × t (optional)

    @classmethod
    def mesh(cls, name, vertices, faces, *, normals=None, tangents=None, uvs=None,
             handedness=None):
        v = np.ascontiguousarray(vertices, np.float32)
        f = np.ascontiguousarray(faces, np.int32)
        if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(f"{name}: vertices (V,3) and faces (F,3) expected")
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise ValueError(f"{name}: face index out of range")
        opt = lambda a, k: None if a is None else np.ascontiguousarray(a, np.float32).reshape(-1, k)
        hand = None if handedness is None else np.asarray(handedness, np.float32).reshape(-1)
        return cls(name, "mesh", v, f, opt(normals, 3), opt(tangents, 3), opt(uvs, 2),
                   handedness=hand)

    @classmethod
    def sphere(cls, name, center, radius, rotation=None):
        return cls(name, "sphere", center=np.asarray(center, float).reshape(3),
                   radius=float(radius),
                   rotation=np.eye(3) if rotation is None else np.asarray(rotation, float))


@dataclass
class GBuffer:
    """Per-ray first hits. Arrays have the rays' leading shape S; misses hold zeros / −1."""

    hit: np.ndarray          # S bool
    t: np.ndarray            # S float32 ray distance (inf on miss)
    position: np.ndarray     # S×3 float32
    normal: np.ndarray       # S×3 float32 shading normal (interpolated, facing the viewer)
    geo_normal: np.ndarray   # S×3 float32 geometric normal (facing the viewer)
    tangent: np.ndarray      # S×3 float32, ⟂ normal
    bitangent: np.ndarray    # S×3 float32, normal × tangent
    uv: np.ndarray           # S×2 float32
    object_id: np.ndarray    # S int32 index into the objects list (−1 miss)
    triangle_id: np.ndarray  # S int32 (−1 for spheres and misses)
    barycentrics: np.ndarray  # S×2 float32 (b0, b1) Embree convention
    view: np.ndarray         # S×3 float32 unit direction towards the viewer (−ray dir)
    backface: np.ndarray     # S bool: the ray met the back side of a triangle
    #: S float32 ±1: a normal map's +Y runs along handedness · bitangent (glTF TANGENT.w);
    #: None: +1 everywhere
    handedness: np.ndarray | None = None
    objects: list = field(default_factory=list, repr=False)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.hit.shape

    def interpolate(self, per_object: list[np.ndarray | None], fill: float = 0.0) -> np.ndarray:
        """Barycentric interpolation of per-vertex attributes (V_k, C) given per object.

        Pixels on objects whose entry is None (or analytic spheres without a mesh) get `fill`.
        """
        chans = {np.asarray(a).reshape(len(a), -1).shape[1] for a in per_object if a is not None}
        if len(chans) > 1:
            raise ValueError(f"attribute channel counts differ between objects: {chans}")
        c = chans.pop() if chans else 1
        out = np.full(self.shape + (c,), fill, np.float32)
        for k, attr in enumerate(per_object):
            if attr is None:
                continue
            obj = self.objects[k]
            sel = (self.object_id == k) & (self.triangle_id >= 0)
            if not sel.any():
                continue
            a = np.asarray(attr, np.float32).reshape(len(attr), -1)
            if obj.kind == "mesh" and len(a) != len(obj.vertices):
                raise ValueError(f"{obj.name}: attribute has {len(a)} rows, mesh has "
                                 f"{len(obj.vertices)} vertices")
            tri = obj.faces[self.triangle_id[sel]]
            b = self.barycentrics[sel]
            w0 = (1.0 - b[:, 0] - b[:, 1])[:, None]
            out[sel] = w0 * a[tri[:, 0]] + b[:, :1] * a[tri[:, 1]] + b[:, 1:] * a[tri[:, 2]]
        return out


def _unit(v):
    n = np.sqrt(np.einsum("...i,...i->...", v, v))[..., None]
    return v / np.where(n > 0, n, 1.0)


def _cross(a, b):
    """Row-wise cross product (faster than np.cross for (N, 3))."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def tangent_frames(n, hint, has_hint):
    """CONVENTIONS frames: t = hint Gram–Schmidt-orthogonalised against n where usable, else the
    azimuthal rule of core.sphere.tangent_frame; b = n × t."""
    t = hint - np.einsum("ij,ij->i", hint, n)[:, None] * n
    ln = np.sqrt(np.einsum("ij,ij->i", t, t))
    ok = has_hint & (ln > 1e-8)
    t = np.where(ok[:, None], t / np.where(ok, ln, 1.0)[:, None], 0.0)
    if (~ok).any():
        t[~ok] = tangent_frame(n[~ok])[0]
    return t, _cross(n, t)


class Tracer:
    """Embree scene for the meshes plus a list of analytic spheres; reusable for many queries."""

    def __init__(self, objects: list[TraceObject]):
        import embreex.rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh

        self.objects = list(objects)
        self._scene = None
        self._geom_to_obj: list[int] = []
        meshes = [k for k, o in enumerate(self.objects) if o.kind == "mesh" and len(o.faces)]
        if meshes:
            self._scene = rtcs.EmbreeScene()
            for k in meshes:  # embreex assigns geomIDs 0, 1, ... in insertion order
                o = self.objects[k]
                TriangleMesh(self._scene, o.vertices, o.faces)
                self._geom_to_obj.append(k)
        self._geom_to_obj_arr = np.asarray(self._geom_to_obj + [-1], np.int32)
        self._spheres = [k for k, o in enumerate(self.objects) if o.kind == "sphere"]

    # -- raw queries ----------------------------------------------------------------------
    def _sphere_hits(self, o, d, tnear):
        """Nearest t > tnear over all analytic spheres (inf if none) and the sphere index."""
        best_t = np.full(len(o), np.inf)
        best_k = np.full(len(o), -1, np.int32)
        for k in self._spheres:
            s = self.objects[k]
            oc = o - s.center
            b = np.einsum("ij,ij->i", oc, d)
            c = np.einsum("ij,ij->i", oc, oc) - s.radius ** 2
            disc = b * b - c
            ok = disc >= 0
            sq = np.sqrt(np.where(ok, disc, 0.0))
            # Stable roots: q = −b − sign(b)·sq, t0 = q, t1 = c/q (rays are unit length).
            q = -b - np.copysign(sq, b)
            qs = np.where(q != 0, q, 1.0)
            ta = np.where(q != 0, q, 0.0)
            tb = np.where(q != 0, c / qs, 0.0)
            t0, t1 = np.minimum(ta, tb), np.maximum(ta, tb)
            t = np.where(t0 > tnear, t0, np.where(t1 > tnear, t1, np.inf))
            t = np.where(ok, t, np.inf)
            closer = t < best_t
            best_t = np.where(closer, t, best_t)
            best_k = np.where(closer, k, best_k)
        return best_t, best_k

    def _embree(self, o, d, tnear, tmax):
        n = len(o)
        if self._scene is None:
            return (np.full(n, np.inf), np.full(n, -1, np.int32), np.full(n, -1, np.int32),
                    np.zeros((n, 2), np.float32), np.zeros((n, 3), np.float32))
        oo = (o + tnear * d).astype(np.float32)  # embreex has no tnear: shift the origin
        dists = np.broadcast_to(np.asarray(tmax, np.float64) - tnear, (n,)).astype(np.float32)
        r = self._scene.run(oo, d.astype(np.float32), dists=dists, output=1)
        g = r["geomID"].astype(np.int32)
        hit = g >= 0
        t = np.where(hit, r["tfar"].astype(float) + tnear, np.inf)
        bary = np.stack([r["u"], r["v"]], -1).astype(np.float32)
        return t, np.where(hit, g, -1), r["primID"].astype(np.int32), bary, r["Ng"]

    def occluded(self, origins, dirs, tmax=np.inf, tnear: float = 1e-4) -> np.ndarray:
        """True where anything lies on the segment (tnear, tmax) of each ray (shadow rays)."""
        shape = np.shape(origins)[:-1]
        o = np.asarray(origins, float).reshape(-1, 3)
        d = _unit(np.asarray(dirs, float).reshape(-1, 3))
        tmax = np.broadcast_to(np.asarray(tmax, float), shape).reshape(-1)
        ts, _ = self._sphere_hits(o, d, tnear)
        blocked = ts < tmax
        if self._scene is not None:
            rest = ~blocked
            if rest.any():
                oo = (o[rest] + tnear * d[rest]).astype(np.float32)
                dist = np.minimum(tmax[rest] - tnear, 3.0e38).astype(np.float32)
                r = self._scene.run(oo, d[rest].astype(np.float32), dists=dist,
                                    query="OCCLUDED")
                blocked[rest] = np.asarray(r) >= 0
        return blocked.reshape(shape)

    # -- G-buffer -------------------------------------------------------------------------
    def trace(self, origins, dirs, tnear: float = 0.0) -> GBuffer:
        """First hits of rays (leading shape S) → GBuffer of shape S."""
        shape = np.shape(origins)[:-1]
        o = np.asarray(origins, float).reshape(-1, 3)
        d = _unit(np.asarray(dirs, float).reshape(-1, 3))
        n = len(o)
        tm, gm, prim, bary, ng_m = self._embree(o, d, tnear, np.inf)
        ts, ks = self._sphere_hits(o, d, tnear)
        use_s = ts < tm
        t = np.where(use_s, ts, tm)
        hit = np.isfinite(t)
        obj = np.where(use_s, ks, self._geom_to_obj_arr[gm]).astype(np.int32)
        obj[~hit] = -1
        tri = np.where(use_s | ~hit, -1, prim).astype(np.int32)
        bary = np.where((tri >= 0)[:, None], bary, 0.0).astype(np.float32)
        pos = np.where(hit[:, None], o + np.where(hit, t, 0.0)[:, None] * d, 0.0)
        nrm = np.zeros((n, 3))
        ngeo = np.zeros((n, 3))
        tan_hint = np.full((n, 3), np.nan)
        hand = np.ones(n)
        uv = np.zeros((n, 2))
        for k, ob in enumerate(self.objects):
            sel = obj == k
            if not sel.any():
                continue
            if ob.kind == "sphere":
                nl = _unit(pos[sel] - ob.center)
                ngeo[sel] = nl
                nrm[sel] = nl
                local = nl @ ob.rotation  # R^T n: object-space normal
                theta = np.arccos(np.clip(local[:, 1], -1.0, 1.0))
                phi = np.mod(np.arctan2(local[:, 0], -local[:, 2]), 2 * np.pi)
                uv[sel] = np.stack([phi / (2 * np.pi), 1.0 - theta / np.pi], -1)
                # Tangent: the world azimuthal rule (as the visibility stage's icosphere frames,
                # so SSDF images line up), not the rotated object's.
                continue
            f = ob.faces[tri[sel]]
            b = bary[sel].astype(float)
            w = np.stack([1.0 - b[:, 0] - b[:, 1], b[:, 0], b[:, 1]], -1)[..., None]
            v = ob.vertices[f].astype(float)
            ng = _unit(_cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]))
            ngeo[sel] = ng
            wf = w[..., 0]
            lerp = lambda a: np.einsum("nk,nkc->nc", wf, a[f])
            nrm[sel] = _unit(lerp(ob.normals)) if ob.normals is not None else ng
            if ob.uvs is not None:
                uv[sel] = lerp(ob.uvs)
            if ob.tangents is not None:
                tan_hint[sel] = lerp(ob.tangents)
            if ob.handedness is not None:
                hand[sel] = np.where(lerp(ob.handedness[:, None])[:, 0] < 0, -1.0, 1.0)
        back = hit & (np.einsum("ij,ij->i", ngeo, d) > 0)
        ngeo[back] *= -1.0
        nrm[back] *= -1.0
        # Interpolated shading normals may face away near silhouettes: keep them in front.
        nrm = np.where(hit[:, None], _unit(nrm), 0.0)
        has_hint = np.isfinite(tan_hint).all(-1)
        tan = np.zeros((n, 3))
        bit = np.zeros((n, 3))
        if hit.any():
            hint = np.where(has_hint[:, None], tan_hint, 0.0)[hit]
            tan[hit], bit[hit] = tangent_frames(nrm[hit], hint, has_hint[hit])
        f32 = lambda a, *k: a.reshape(shape + tuple(k)).astype(np.float32)
        return GBuffer(hit=hit.reshape(shape), t=f32(t), position=f32(pos, 3),
                       normal=f32(nrm, 3), geo_normal=f32(ngeo, 3), tangent=f32(tan, 3),
                       bitangent=f32(bit, 3), uv=f32(uv, 2), object_id=obj.reshape(shape),
                       triangle_id=tri.reshape(shape), barycentrics=f32(bary, 2),
                       view=f32(np.where(hit[:, None], -d, 0.0), 3),
                       backface=back.reshape(shape), objects=self.objects,
                       handedness=None if all(ob.handedness is None for ob in self.objects)
                       else f32(np.where(hit, hand, 1.0)))


def trace_gbuffer(objects: list[TraceObject], origins, dirs) -> GBuffer:
    """Primary visibility for rays (leading shape S) against `objects` → GBuffer of shape S."""
    return Tracer(objects).trace(origins, dirs)
