"""Embree occlusion tracing of per-vertex hemisphere visibility (Wang09 §5.2).

Embree scenes cannot be pickled: each worker process builds the scene once from a triangle
file and keeps it in a module global. Work items are vertex ranges; per-vertex memory is
one trace image of rays, so memory is bounded by the chunk, not the mesh.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from sgpipe.visibility import _rays_jit
from sgpipe.visibility.hemigrid import texel_dirs_f32
from sgpipe.visibility.ssdf import ssdf_from_visibility

_SCENE: dict = {"key": None, "scene": None}


def build_scene(triangles: np.ndarray):
    """An embreex scene of (F, 3, 3) triangles (float32 world corners)."""
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh
    tri = np.ascontiguousarray(triangles, dtype=np.float32).reshape(-1, 3, 3)
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, tri)
    return scene


def scene_from_file(path: str):
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
    if buffers is None or len(buffers.o) < len(local):
        buffers = RayBuffers(len(local))
    origin = np.asarray(position, np.float64) + offset * np.asarray(normal, np.float64)
    m = _rays_jit.fill_rays(local, idx, np.asarray(tangent, np.float64),
                            np.asarray(bitangent, np.float64), np.asarray(normal, np.float64),
                            origin, buffers.o, buffers.d)
    return buffers.o[:m], buffers.d[:m]


def occluded(scene, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Bool per ray: the ray hits something (embreex OCCLUDED query returns −1 for a miss)."""
    return scene.run(origins, dirs, query="OCCLUDED") != -1


@lru_cache(maxsize=4)
def _coarse_index(trace_res: int, res: int) -> np.ndarray:
    """Flat trace-texel index of one ray near the centre of every k×k block (k = T/R)."""
    k = trace_res // res
    c = np.arange(res) * k + k // 2
    return (c[:, None] * trace_res + c[None, :]).ravel().astype(np.int64)


def _block_texels(trace_res: int, res: int, mask: np.ndarray) -> np.ndarray:
    k = trace_res // res
    bi, bj = np.nonzero(mask)
    off = (np.arange(k)[:, None] * trace_res + np.arange(k)[None, :]).ravel()
    base = (bi * k) * trace_res + bj * k
    return (base[:, None] + off[None, :]).ravel().astype(np.int64)


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
    """((T, T) bool visibility, number of rays traced) of one vertex's upper hemisphere (True = unoccluded).

    sampling="full" traces every trace texel (Wang09 §5.2). "adaptive" traces one ray per
    k×k block of the R×R output grid, then every ray of the blocks within `margin` blocks of
    a change; other blocks take their coarse value (misses occluders smaller than a block)."""
    frame = (position, normal, tangent, bitangent, trace_res, offset, buffers)
    if sampling == "full":
        o, d = hemisphere_rays(*frame)
        return (scene.run(o, d, query="OCCLUDED") == -1).reshape(trace_res, trace_res), len(o)
    if sampling != "adaptive" or res is None:
        raise ValueError("sampling must be 'full' or 'adaptive' (with res)")
    k = trace_res // res
    o, d = hemisphere_rays(*frame, idx=_coarse_index(trace_res, res))
    coarse = (scene.run(o, d, query="OCCLUDED") == -1).reshape(res, res)
    vis = np.repeat(np.repeat(coarse, k, axis=0), k, axis=1)
    rays = len(o)
    mask = _rays_jit.refine_mask(coarse, int(margin))
    if mask.any():
        idx = _block_texels(trace_res, res, mask)
        o, d = hemisphere_rays(*frame, idx=idx)
        vis.ravel()[idx] = scene.run(o, d, query="OCCLUDED") == -1
        rays += len(o)
    return vis, rays


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


__all__ = ["build_scene", "scene_from_file", "hemisphere_rays", "occluded", "trace_visibility",
           "trace_visibility_counted", "RayBuffers", "TraceTask", "TraceResult", "trace_chunk"]
