"""Embree occlusion tracing of per-vertex hemisphere visibility (Wang09 §5.2).

Embree scenes cannot be pickled: each worker process builds the scene once from a triangle
file and keeps it in a module global. Work items are vertex ranges; per-vertex memory is
one trace image of rays, so memory is bounded by the chunk, not the mesh.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from sgpipe.visibility import _rays_jit
from sgpipe.visibility import _silhouette_jit as _sil
from sgpipe.visibility.hemigrid import texel_dirs_f32
from sgpipe.visibility.silhouette import PAD, EdgeTable, edge_table, silhouette_mark
from sgpipe.visibility.ssdf import ssdf_from_visibility

_SCENE: dict = {"key": None, "scene": None}


class TracedScene:
    """An embreex scene with the float32 triangles it holds (their edges guide the adaptive
    sampler); `run` is embreex's."""

    def __init__(self, triangles: np.ndarray):
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh
        self.triangles = np.ascontiguousarray(triangles, dtype=np.float32).reshape(-1, 3, 3)
        self.embree = rtcs.EmbreeScene()
        TriangleMesh(self.embree, self.triangles)
        self._edges = None

    def run(self, *args, **kwargs):
        """embreex's EmbreeScene.run (origins, directions, query=...)."""
        return self.embree.run(*args, **kwargs)

    @property
    def edges(self) -> EdgeTable:
        """The welded edge table of the triangles (built on first use)."""
        if self._edges is None:
            self._edges = edge_table(self.triangles)
        return self._edges


def build_scene(triangles: np.ndarray) -> TracedScene:
    """A traced scene of (F, 3, 3) triangles (float32 world corners)."""
    return TracedScene(triangles)


def scene_from_file(path: str) -> TracedScene:
    """The scene of a triangle .npy file, built once per process and cached."""
    st = os.stat(path)
    key = (path, st.st_size, st.st_mtime_ns)
    if _SCENE["key"] != key:
        _SCENE["scene"] = build_scene(np.load(path, allow_pickle=False))
        _SCENE["key"] = key
    return _SCENE["scene"]


class RayBuffers:
    """Reusable float32 origin/direction arrays (one trace image per vertex)."""

    def __init__(self, n: int):
        self.o = np.empty((n, 3), np.float32)
        self.d = np.empty((n, 3), np.float32)


_ALL = np.zeros(0, np.int64)


def hemisphere_rays(position, normal, tangent, bitangent, trace_res: int, offset: float,
                    buffers: RayBuffers | None = None, idx: np.ndarray = _ALL):
    """Occlusion rays through the trace texels `idx` (all when empty) of one vertex:
    (origins, dirs) float32 (m, 3). Origins sit `offset` along the normal (self-intersection
    guard: Embree's tnear is 0 in embreex)."""
    local = texel_dirs_f32(trace_res)
    need = len(local) if len(idx) == 0 else len(idx)
    if buffers is None or len(buffers.o) < need:
        buffers = RayBuffers(need)
    origin = np.asarray(position, np.float64) + offset * np.asarray(normal, np.float64)
    m = _rays_jit.fill_rays(local, idx, np.asarray(tangent, np.float64),
                            np.asarray(bitangent, np.float64), np.asarray(normal, np.float64),
                            origin, buffers.o, buffers.d)
    return buffers.o[:m], buffers.d[:m]


def occluded(scene, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Bool per ray: the ray hits something (embreex OCCLUDED query returns −1 for a miss)."""
    return scene.run(origins, dirs, query="OCCLUDED") != -1


def _visible(scene, origins, dirs) -> np.ndarray:
    """Bool per ray: nothing hit (embreex's OCCLUDED query returns −1 for a miss)."""
    return scene.run(origins, dirs, query="OCCLUDED") == -1


def _trace_adaptive(scene, frame, margin: int):
    """Silhouette-guided trace (see silhouette.py): every texel within the band of a
    projected contour or open edge, three probes per region away from them; a region whose
    probes disagree is traced whole. Returns ((T, T) visibility, rays traced)."""
    position, normal, tangent, bitangent, trace_res, offset, buffers = frame
    origin = (np.asarray(position, np.float64) + offset * np.asarray(normal, np.float64)
              ).astype(np.float32).astype(np.float64)      # where the float32 rays start
    mark = silhouette_mark(scene.edges, origin, tangent, bitangent, normal, trace_res,
                           PAD + (int(margin) - 1))
    if mark is None:
        o, d = hemisphere_rays(*frame)
        return _visible(scene, o, d).reshape(trace_res, trace_res), len(o)
    rr, r0, r1, region, m = _sil.unmarked_regions(mark)
    probes = _sil.probe_texels(rr, r0, r1, region, m, trace_res)
    marked = np.flatnonzero(mark.ravel())
    o, d = hemisphere_rays(*frame, idx=np.concatenate([marked, probes.ravel()]))
    hit = _visible(scene, o, d)
    rays = len(o)
    vis = np.empty((trace_res, trace_res), np.bool_)
    vis.ravel()[marked] = hit[:len(marked)]
    pv = hit[len(marked):].reshape(m, 3)
    _sil.fill_regions(vis, rr, r0, r1, region, pv[:, 0].copy())
    split = pv.any(axis=1) & ~pv.all(axis=1)
    if split.any():                   # the bound failed (a leaking shared edge): trace them
        idx = _sil.region_texels(rr, r0, r1, region, split, trace_res)
        o, d = hemisphere_rays(*frame, idx=idx)
        vis.ravel()[idx] = _visible(scene, o, d)
        rays += len(o)
    return vis, rays


def trace_visibility(scene, position, normal, tangent, bitangent, trace_res: int,
                     offset: float, *, sampling: str = "full", res: int | None = None,
                     margin: int = 1, buffers: RayBuffers | None = None) -> np.ndarray:
    """(T, T) bool visibility of one vertex's upper hemisphere (True = unoccluded); see
    trace_visibility_counted."""
    return trace_visibility_counted(scene, position, normal, tangent, bitangent, trace_res,
                                    offset, sampling=sampling, res=res, margin=margin,
                                    buffers=buffers)[0]


def trace_visibility_counted(scene, position, normal, tangent, bitangent, trace_res: int,
                             offset: float, *, sampling: str = "full", res: int | None = None,
                             margin: int = 1, buffers: RayBuffers | None = None):
    """((T, T) bool visibility, number of rays traced) of one vertex's upper hemisphere
    (True = unoccluded).

    sampling="full" traces every trace texel (Wang09 §5.2). "adaptive" traces the texels
    within PAD + margin − 1 texels of a projected contour or open edge of the scene and three
    rays per connected region of the rest (silhouette.py): the same image wherever Embree's
    edge tests are watertight. `res` is accepted for the caller's convenience and unused."""
    frame = (position, normal, tangent, bitangent, trace_res, offset, buffers)
    if sampling == "full":
        o, d = hemisphere_rays(*frame)
        return _visible(scene, o, d).reshape(trace_res, trace_res), len(o)
    if sampling != "adaptive":
        raise ValueError("sampling must be 'full' or 'adaptive'")
    if not hasattr(scene, "edges"):
        raise TypeError("adaptive sampling needs a scene from build_scene (its edges)")
    return _trace_adaptive(scene, frame, margin)


@dataclass
class TraceTask:
    """One vertex range of one object; SSDF rows go to rows [start, stop) of `ssdf_path`."""

    triangles_path: str
    ssdf_path: str
    n_rows: int
    start: int
    stop: int
    positions: np.ndarray
    normals: np.ndarray
    tangents: np.ndarray
    bitangents: np.ndarray
    trace_res: int
    res: int
    offset: float
    max_distance: float
    sampling: str = "full"
    margin: int = 1


@dataclass
class TraceResult:
    start: int
    stop: int
    visible_fraction: np.ndarray   # (n,) fraction of unoccluded rays per vertex
    rays: int
    trace_s: float                 # ray generation + Embree (wall)
    ssdf_s: float                  # downsample + signed distance (wall)
    cpu_s: float = 0.0             # CPU time of the whole chunk (this worker process)


def trace_chunk(task: TraceTask) -> TraceResult:
    """Trace, downsample and convert one vertex range; writes its SSDF rows to the memmap."""
    c0 = time.process_time()
    scene = scene_from_file(task.triangles_path)
    n = task.stop - task.start
    d = task.res * task.res
    out = np.memmap(task.ssdf_path, dtype=np.float32, mode="r+", shape=(task.n_rows, d))
    frac = np.empty(n)
    t_trace = t_ssdf = 0.0
    rays = 0
    buffers = RayBuffers(task.trace_res ** 2)
    rows = np.empty((n, d), np.float32)
    for i in range(n):
        t0 = time.perf_counter()
        vis, m = trace_visibility_counted(
            scene, task.positions[i], task.normals[i], task.tangents[i], task.bitangents[i],
            task.trace_res, task.offset, sampling=task.sampling, res=task.res,
            margin=task.margin, buffers=buffers)
        t1 = time.perf_counter()
        rays += m
        frac[i] = vis.mean()
        rows[i] = ssdf_from_visibility(vis, task.res, max_distance=task.max_distance).ravel()
        t_trace += t1 - t0
        t_ssdf += time.perf_counter() - t1
    out[task.start:task.stop] = rows
    out.flush()
    del out
    return TraceResult(task.start, task.stop, frac, rays, t_trace, t_ssdf,
                       time.process_time() - c0)


__all__ = ["TracedScene", "build_scene", "scene_from_file", "hemisphere_rays", "occluded",
           "trace_visibility", "trace_visibility_counted", "RayBuffers", "TraceTask",
           "TraceResult", "trace_chunk"]
