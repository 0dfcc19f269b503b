"""Green06 §4.1 eq 2: direct glossy transport T_{x,v}(ω_i) = f_s(ω_i, v) V_x(ω_i) (n·ω_i)
sampled at the texels of a cubemap of light directions, for the 92 global view directions;
and eq 5's indirect glossy part T^IG by BRDF-importance-sampled path tracing along v.

Visibility is view-independent, so it is traced once per vertex (one Embree occlusion query per
light texel, with the visibility stage's scene and `occluded`); the BRDF × cosine is then
evaluated for every view above the vertex's horizon. Views below the horizon get T = 0.

Indirect (§4.1: "the path of each photon until it is absorbed or reflected off to infinity,
where it is stored in the corresponding cubemap texel"): from x a direction is drawn from the
specular lobe f_s(·, v) (the diffuse part at x is the SH transfer's), traced; where it meets
another surface the path goes on by that surface's BRDF importance sample, up to `bounces`
surfaces; a path leaving the scene after at least one surface adds its throughput
Π f·cos/p / (paths · Ω_j) to the texel j of its last direction, so Σ_j T_j Ω_j L_j estimates the
interreflected glossy radiance. A first segment that leaves the scene is direct (eq 2 above).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from sgpipe.core.maps import cubemap_solid_angles, cubemap_texel_dirs, dir_to_cubemap
from sgpipe.core.sphere import to_local, to_world
from sgpipe.visibility.trace import occluded

#: light-cube face resolutions the transport stage accepts (6·res² texels)
SUPPORTED_CUBE_RESOLUTIONS = (4, 8, 16, 32, 64)


@dataclass(frozen=True)
class LightCube:
    """Texel-centre directions (M, 3) and exact solid angles (M,) of a 6×res² cubemap,
    flattened in CONVENTIONS face/row/column order."""

    res: int
    dirs: np.ndarray
    omega: np.ndarray


@lru_cache(maxsize=8)
def light_cube(res: int) -> LightCube:
    """The light cube of face resolution `res` (CONVENTIONS cubemap layout)."""
    d = cubemap_texel_dirs(res).reshape(-1, 3)
    w = cubemap_solid_angles(res).reshape(-1)
    d.setflags(write=False)
    w.setflags(write=False)
    return LightCube(int(res), d, w)


def vertex_visibility(scene, position, normal, dirs, offset: float) -> np.ndarray:
    """(M,) bool: light direction unoccluded from the vertex (False below its horizon). Rays
    start `offset` along the normal, as in the visibility stage."""
    up = dirs @ normal > 0.0
    vis = np.zeros(len(dirs), bool)
    if scene is None:
        vis[:] = up
        return vis
    o = np.asarray(position, np.float64) + offset * np.asarray(normal, np.float64)
    idx = np.flatnonzero(up)
    if len(idx):
        origins = np.broadcast_to(o.astype(np.float32), (len(idx), 3)).copy()
        vis[idx] = ~occluded(scene, origins, np.ascontiguousarray(dirs[idx], np.float32))
    return vis


def vertex_transport(brdf, normal, tangent, bitangent, views, light: LightCube,
                     visibility: np.ndarray, min_cos: float = 0.0
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(T (V, M, 3) float64, active (V,) bool): eq 2 with the specular lobe f_s for every
    view v (rows of `views`, pointing away from the surface); views with n·v <= min_cos are
    inactive and their T is zero. (A view grazing the tangent plane sees no projected area,
    while some BRDFs — Ward's 1/√(cos θ_o) — diverge there.) The diffuse part is the
    view-independent SH transfer."""
    n_views, m = len(views), len(light.dirs)
    T = np.zeros((n_views, m, 3))
    active = views @ normal > min_cos
    lit = np.flatnonzero(visibility)
    if not brdf.has_specular or not len(lit) or not active.any():
        return T, active
    i_loc = to_local(light.dirs[lit], normal, tangent, bitangent)       # (L, 3)
    o_loc = to_local(views[active], normal, tangent, bitangent)          # (A, 3)
    f = brdf.specular(o_loc[:, None, :], i_loc[None, :, :])              # (A, L, 3)
    T[np.ix_(np.flatnonzero(active), lit)] = f * np.maximum(i_loc[:, 2], 0.0)[None, :, None]
    return T, active


def cube_texel(light: LightCube, dirs) -> np.ndarray:
    """Flat light-cube texel index (N,) of world directions (N, 3)."""
    face, s, t = dir_to_cubemap(dirs)
    n = light.res
    col = np.clip((s * n).astype(np.int64), 0, n - 1)
    row = np.clip((t * n).astype(np.int64), 0, n - 1)
    return (face * n + row) * n + col


class PathScene:
    """The scene the indirect paths run through: `sgpipe.scene.gbuffer.TraceObject` meshes
    (with their shading normals and tangents) and one BRDF (model, params) per object. It
    pickles (the Embree tracer and BRDFs are built in the process that uses them)."""

    def __init__(self, objects, materials):
        self.objects = list(objects)
        self.materials = [(str(m), dict(p or {})) for m, p in materials]
        self._built = None

    def __getstate__(self):
        return {"objects": self.objects, "materials": self.materials, "_built": None}

    @classmethod
    def from_geometry(cls, geoms, materials) -> "PathScene":
        """From `sgpipe.io.mesh.MeshGeometry` objects (world positions, normals, tangents,
        faces) and their (model, params)."""
        from sgpipe.scene.gbuffer import TraceObject
        return cls([TraceObject.mesh(g.name, g.positions, g.faces, normals=g.normals,
                                     tangents=g.tangents) for g in geoms], materials)

    def built(self):
        """(Tracer, [BRDF per object]), made once."""
        if self._built is None:
            from sgpipe.brdf import make_brdf
            from sgpipe.scene.gbuffer import Tracer
            self._built = (Tracer(self.objects), [make_brdf(m, p) for m, p in self.materials])
        return self._built


def follow_paths(scene: PathScene, origins, dirs, beta, bounces: int, offset: float, rng):
    """Trace rays (P, 3) carrying throughputs beta (P, 3); where they meet a surface, go on by
    its BRDF importance sample (throughput × f·cos/p), up to `bounces` surfaces. Returns the
    paths that leave the scene after ≥ 1 surface: (ray index (Q,), direction (Q, 3),
    throughput (Q, 3)). Rays that miss at once and paths still inside after the last bounce
    are dropped; continuations start `offset` along the geometric normal."""
    tracer, brdfs = scene.built()
    idx = np.arange(len(dirs))
    o, d, b = (np.asarray(a, np.float64) for a in (origins, dirs, beta))
    out_i, out_d, out_b = [], [], []
    for k in range(bounces + 1):
        if len(idx) == 0:
            break
        gb = tracer.trace(o, d)
        if k > 0:
            miss = ~gb.hit
            out_i.append(idx[miss])
            out_d.append(d[miss])
            out_b.append(b[miss])
        if k == bounces:
            break
        h = np.flatnonzero(gb.hit)
        n, t, bt, ng = (np.asarray(a[h], np.float64) for a in (gb.normal, gb.tangent,
                                                               gb.bitangent, gb.geo_normal))
        obj = gb.object_id[h]
        view = -d[h]
        u = rng.random((len(h), 2))
        nd, w = np.zeros((len(h), 3)), np.zeros((len(h), 3))
        for m in np.unique(obj):
            sel = np.flatnonzero(obj == m)
            o_loc = to_local(view[sel], n[sel], t[sel], bt[sel])
            i_loc, p = brdfs[m].sample(o_loc, u[sel, 0], u[sel, 1])
            f = brdfs[m].eval(o_loc, i_loc)
            wd = to_world(i_loc, n[sel], t[sel], bt[sel])
            ok = (p > 0) & (i_loc[:, 2] > 0) & (np.sum(wd * ng[sel], -1) > 0)
            nd[sel] = wd
            w[sel] = np.where(ok[:, None], f * (i_loc[:, 2] / np.where(ok, p, 1.0))[:, None],
                              0.0)
        live = np.flatnonzero((w > 0).any(axis=1))
        idx, d = idx[h[live]], nd[live] / np.linalg.norm(nd[live], axis=1, keepdims=True)
        b = b[h[live]] * w[live]
        o = np.asarray(gb.position[h[live]], np.float64) + offset * ng[live]
    if not out_i:
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3))
    return np.concatenate(out_i), np.concatenate(out_d), np.concatenate(out_b)


def indirect_exits(scene: PathScene, brdf, position, normal, tangent, bitangent, views,
                   active, *, paths: int, bounces: int, offset: float, rng):
    """Eq 5's indirect paths of the active views: `paths` specular-lobe samples per view, each
    followed through up to `bounces` other surfaces. Returns the paths that leave the scene:
    (active-view index a (Q,), path slot (Q,) in [0, paths), exit direction (Q, 3), estimator
    weight (Q, 3) = throughput / paths, so Σ weight g(d) over a view's exits estimates
    ∫ T^IG g dω)."""
    act = np.flatnonzero(active)
    empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3)))
    if not brdf.has_specular or len(act) == 0 or bounces < 1:
        return empty
    o_loc = np.repeat(to_local(views[act], normal, tangent, bitangent), paths, axis=0)
    # stratified over each view's `paths` samples (jittered rows of u1)
    u1 = (np.tile(np.arange(paths), len(act)) + rng.random(len(o_loc))) / paths
    u2 = rng.random(len(o_loc))
    i_loc, p = brdf.sample(o_loc, u1, u2, lobe="specular")
    f = brdf.specular(o_loc, i_loc)
    ok = (p > 0) & (i_loc[:, 2] > 0)
    w = np.where(ok[:, None], f * (i_loc[:, 2] / np.where(ok, p, 1.0))[:, None], 0.0)
    go = np.flatnonzero((w > 0).any(axis=1))
    dirs = to_world(i_loc[go], normal, tangent, bitangent)
    origin = np.asarray(position, np.float64) + offset * np.asarray(normal, np.float64)
    ray, d, beta = follow_paths(scene, np.broadcast_to(origin, dirs.shape), dirs, w[go],
                                bounces, offset, rng)
    return go[ray] // paths, go[ray] % paths, d, beta / paths


def vertex_indirect_transport(scene: PathScene, brdf, position, normal, tangent, bitangent,
                              views, active, light: LightCube, *, paths: int, bounces: int,
                              offset: float, rng) -> np.ndarray:
    """T^IG (V, M, 3) of Green06 eq 5 for the active views (module docstring): the exits of
    `indirect_exits` binned into the light cube's texels."""
    T = np.zeros((len(views), len(light.dirs), 3))
    a, _, d, wgt = indirect_exits(scene, brdf, position, normal, tangent, bitangent, views,
                                  active, paths=paths, bounces=bounces, offset=offset, rng=rng)
    j = cube_texel(light, d)
    np.add.at(T, (np.flatnonzero(active)[a], j), wgt / light.omega[j][:, None])
    return T


__all__ = ["SUPPORTED_CUBE_RESOLUTIONS", "LightCube", "light_cube", "vertex_visibility",
           "vertex_transport", "cube_texel", "PathScene", "follow_paths",
           "indirect_exits", "vertex_indirect_transport"]
