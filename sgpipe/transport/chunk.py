"""One parallel work item of the transport stage: a contiguous range of the flood-fill vertex
order. Per vertex: trace visibility over the light cube and its SH transfer; then with
`sampling: cube` sample the direct glossy transport for the 92 views at the cube's texels
(eq 2) and fit the Gaussians (eq 6) — starting from an already fitted neighbour in the same
chunk (or, with `TransportTask.prior`, fitted by an earlier chunk) and holding the fitted
neighbours' means in the spatial term (Green06 §4.2's flood fill) —, with `sampling: lobe`
sample each view's specular lobe and set its Gaussians from those samples (`lobe_fit`). The
transport itself is never stored: it lives for one vertex. With `TransportTask.indirect` the
indirect glossy part T^IG (eq 5) is added to T before the fit and the interreflected SH
transfer is kept beside the shadowed one; each vertex's random numbers come from its own
generator seeded by (config seed, object, vertex), so no result depends on which chunk or
worker a vertex fell into. With `TransportTask.vertex_materials` each vertex's transport is
that of its own BRDF (a textured material filtered to the vertex spacing: `vertex_material`).

Chunks depend only on their inputs (never on the worker count), so the artifacts are the same
bytes for any number of workers; with transport.flood_fill "mesh" a chunk's inputs include
the earlier chunks' fits (`prior`), and the stage runs them in order.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass

import numpy as np

from sgpipe.brdf import make_brdf
from sgpipe.transport.fit import (FitOptions, VertexFit, VertexProblem, fit_vertex,
                                  init_from_neighbour, init_params, negligible_transport)
from sgpipe.transport.lobe_fit import (EXTRAPOLATE_COS, lobe_gaussians, lobe_samples,
                                       raised_views, sample_error, shadow_samples)
from sgpipe.transport.sampling import (PathScene, indirect_exits, light_cube,
                                       vertex_indirect_transport, vertex_transport,
                                       vertex_visibility)
from sgpipe.transport.sh_transfer import interreflected_transfer, texel_basis, transfer_vector
from sgpipe.transport.vertex_material import VertexMaterials
from sgpipe.transport.views import view_set
from sgpipe.visibility.trace import scene_from_file

MAX_SPATIAL_NEIGHBOURS = 4


def vertex_adjacency(faces: np.ndarray, n: int) -> list[np.ndarray]:
    """Sorted neighbour indices of every vertex (mesh edges)."""
    f = np.asarray(faces, np.int64)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    e = np.unique(np.concatenate([e, e[:, ::-1]]), axis=0)
    starts = np.searchsorted(e[:, 0], np.arange(n + 1))
    return [e[starts[i]:starts[i + 1], 1] for i in range(n)]


def flood_order(adjacency: list[np.ndarray], seed: int = 0) -> np.ndarray:
    """Breadth-first vertex order from `seed` (then from the lowest unvisited vertex of every
    further component): each vertex after a component's first has a neighbour before it."""
    n = len(adjacency)
    seen = np.zeros(n, bool)
    order = []
    for root in [seed, *range(n)]:
        if seen[root]:
            continue
        seen[root] = True
        q = deque([root])
        while q:
            v = q.popleft()
            order.append(v)
            for u in adjacency[v]:
                if not seen[u]:
                    seen[u] = True
                    q.append(u)
    return np.asarray(order, np.int64)


@dataclass
class TransportTask:
    """Vertices `order` (global indices, flood-fill order) of one object and their mesh
    neighbours; the BRDF as (model, params) so that the task pickles."""

    triangles_path: str | None
    order: np.ndarray
    positions: np.ndarray
    normals: np.ndarray
    tangents: np.ndarray
    bitangents: np.ndarray
    neighbours: list
    brdf_model: str
    brdf_params: dict
    cube_res: int
    offset: float
    opts: FitOptions
    min_cos: float = 0.0
    #: transport.indirect's paths, or None for direct transport only
    indirect: "IndirectOptions | None" = None
    #: "cube" (Green06's light-cube samples fitted by eq 6) or "lobe" (lobe_fit's samples)
    sampling: str = "lobe"
    #: lobe samples per view with sampling "lobe"
    lobe_samples: int = 128
    #: transport.flood_fill "mesh": the fits (mu, sigma, w) of this chunk's vertices'
    #: neighbours that earlier chunks fitted, by global vertex
    prior: "dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] | None" = None
    #: per vertex of `order` its own material (transport.vertex_materials on a textured
    #: gltf_pbr object: vertex_material.VertexMaterials), or None: every vertex the BRDF above
    vertex_materials: "VertexMaterials | None" = None


@dataclass
class IndirectOptions:
    """The indirect transport of one object's vertices (Green06 §4.1 eq 5): the scene the
    paths run through, the object's index and the config seed (the per-vertex RNG streams)."""

    scene: PathScene
    object_index: int
    seed: int
    bounces: int
    paths: int
    transfer_paths: int

    def vertex_rng(self, vertex: int) -> np.random.Generator:
        """The random stream of one vertex, whatever chunk or worker it runs in."""
        return np.random.default_rng([self.seed, self.object_index, int(vertex)])


@dataclass
class TransportResult:
    order: np.ndarray
    mu: np.ndarray          # (n, 92, K, 3)
    sigma: np.ndarray       # (n, 92, K)
    w: np.ndarray           # (n, 92, K, 3)
    sh: np.ndarray          # (n, 25) shadowed transfer
    rel_err: np.ndarray     # (n,) relative L2 error of the fit over all active views (pooled)
    iters: np.ndarray       # (n,)
    visible: np.ndarray     # (n,) fraction of the upper-hemisphere light texels unoccluded
    sh_indirect: np.ndarray = None  # (n, 25, 3) interreflected transfer (zero without indirect)
    #: with sampling "lobe": the same Gaussians fitted to the unshadowed direct samples (the
    #: renderer's glossy visibility ratio divides by them); None with "cube"
    mu_open: np.ndarray = None
    sigma_open: np.ndarray = None
    w_open: np.ndarray = None
    #: (n,) bool: rows with glossy transport that were fitted (the others have zero weights;
    #: they seed no neighbour)
    fitted_rows: np.ndarray = None
    transport_s: float = 0.0
    fit_s: float = 0.0
    cpu_s: float = 0.0

    @property
    def fitted(self) -> int:
        """Vertices with glossy transport."""
        return int(self.fitted_rows.sum())


def run_chunk(task: TransportTask) -> TransportResult:
    """Sample and fit every vertex of the chunk in flood-fill order."""
    c0 = time.process_time()
    scene = scene_from_file(task.triangles_path) if task.triangles_path else None
    brdf = make_brdf(task.brdf_model, task.brdf_params)
    cube = light_cube(task.cube_res)
    views = view_set()[0]
    basis = texel_basis(cube)
    n, K = len(task.order), task.opts.gaussians
    res = TransportResult(task.order, np.zeros((n, 92, K, 3)), np.zeros((n, 92, K)),
                          np.zeros((n, 92, K, 3)), np.zeros((n, basis.shape[1])), np.zeros(n),
                          np.zeros(n, np.int64), np.zeros(n), np.zeros((n, basis.shape[1], 3)),
                          fitted_rows=np.zeros(n, bool))
    if task.sampling == "lobe":
        res.mu_open, res.sigma_open = np.zeros((n, 92, K, 3)), np.zeros((n, 92, K))
        res.w_open = np.zeros((n, 92, K, 3))
    ind = task.indirect
    done: dict[int, int] = {}         # global vertex → row of res
    vmat = task.vertex_materials
    for i in range(n):
        t0 = time.perf_counter()
        if vmat is not None:      # the vertex's own BRDF (Green06 Fig 1's varying material)
            brdf = make_brdf("gltf_pbr", vmat.brdf_params(i))
        nrm, tan, bit = task.normals[i], task.tangents[i], task.bitangents[i]
        vis = vertex_visibility(scene, task.positions[i], nrm, cube.dirs, task.offset)
        res.sh[i] = transfer_vector(basis, cube, nrm, vis)
        up = cube.dirs @ nrm > 0
        res.visible[i] = vis[up].mean() if up.any() else 0.0
        if task.sampling == "lobe":
            _fit_lobe_vertex(task, i, scene, brdf, views, cube, vis, res)
            res.transport_s += time.perf_counter() - t0
            continue
        T, active = vertex_transport(brdf, nrm, tan, bit, views, cube, vis, task.min_cos)
        if ind is not None:
            rng = ind.vertex_rng(task.order[i])
            T = T + vertex_indirect_transport(ind.scene, brdf, task.positions[i], nrm, tan, bit,
                                              views, active, cube, paths=ind.paths,
                                              bounces=ind.bounces, offset=task.offset, rng=rng)
            res.sh_indirect[i] = interreflected_transfer(
                ind.scene, cube, task.positions[i], nrm, vis, paths=ind.transfer_paths,
                bounces=ind.bounces, offset=task.offset, rng=rng)
        t1 = time.perf_counter()
        if negligible_transport(T[active]):
            # no glossy transport at all (a diffuse material, a fully shadowed vertex, only a
            # sharp lobe's far tail): zero weights, nothing stored; not a flood-fill start for
            # its neighbours
            res.mu[i] = views[:, None, :]
            res.sigma[i] = task.opts.sigma_max
            res.fit_s += time.perf_counter() - t1
            res.transport_s += t1 - t0
            continue
        prior = task.prior or {}
        fits = [(res.mu[done[u]], res.sigma[done[u]], res.w[done[u]]) if u in done
                else prior[u] for u in task.neighbours[i]
                if u in done or u in prior][:MAX_SPATIAL_NEIGHBOURS]
        nb_means = np.stack([f[0] for f in fits]) if fits and K > 1 else None
        prob = VertexProblem(T, active, cube.dirs, cube.omega, task.opts, nrm, nb_means)
        if fits:
            start = init_from_neighbour(prob, VertexFit(*fits[0], 0.0, 0.0, 0))
        else:
            start = init_params(prob)
        fit = fit_vertex(prob, start)
        res.fitted_rows[i] = True
        res.mu[i], res.sigma[i], res.w[i] = fit.mu, fit.sigma, fit.w
        res.rel_err[i], res.iters[i] = fit.rel_err, fit.iters
        done[int(task.order[i])] = i
        res.transport_s += t1 - t0
        res.fit_s += time.perf_counter() - t1
    res.cpu_s = time.process_time() - c0
    return res


def _fit_lobe_vertex(task: TransportTask, i: int, scene, brdf, views, cube, vis,
                     res: TransportResult) -> None:
    """Row i's Gaussians by `transport.sampling: lobe` (lobe_fit): each view's specular-lobe
    samples, shadowed by traced rays (plus the indirect paths' exits), set the view's
    Gaussians (`lobe_gaussians`); with indirect, also the interreflected SH transfer."""
    nrm, tan, bit, pos = task.normals[i], task.tangents[i], task.bitangents[i], task.positions[i]
    active = views @ nrm > EXTRAPOLATE_COS
    fit_views = raised_views(views, nrm, tan, task.min_cos)
    res.mu[i], res.sigma[i] = views[:, None, :], task.opts.sigma_max
    res.mu_open[i], res.sigma_open[i] = views[:, None, :], task.opts.sigma_max
    if not brdf.has_specular or not active.any():
        return
    dirs, wgt, q = lobe_samples(brdf, nrm, tan, bit, fit_views, active, task.lobe_samples)
    # the unshadowed lobe, fitted alike (same samples, same rule): where nothing occludes the
    # vertex the two sets are equal and the renderer's ratio of the two is exactly 1
    if not negligible_transport(wgt):
        res.mu_open[i], res.sigma_open[i], res.w_open[i] = lobe_gaussians(
            dirs, wgt, views, active, task.opts.sigma_min, task.opts.sigma_max,
            task.opts.gaussians, nrm)
    wgt = shadow_samples(scene, pos, nrm, dirs, wgt, task.offset)
    d_all, w_all = dirs, wgt
    ind = task.indirect
    if ind is not None:
        rng = ind.vertex_rng(task.order[i])
        a, slot, d, wi = indirect_exits(ind.scene, brdf, pos, nrm, tan, bit, fit_views, active,
                                        paths=ind.paths, bounces=ind.bounces,
                                        offset=task.offset, rng=rng)
        n_act = int(active.sum())
        d_ind, w_ind = np.zeros((n_act, ind.paths, 3)), np.zeros((n_act, ind.paths, 3))
        d_ind[a, slot], w_ind[a, slot] = d, wi
        d_all, w_all = np.concatenate([dirs, d_ind], 1), np.concatenate([wgt, w_ind], 1)
        res.sh_indirect[i] = interreflected_transfer(
            ind.scene, cube, pos, nrm, vis, paths=ind.transfer_paths, bounces=ind.bounces,
            offset=task.offset, rng=rng)
    if negligible_transport(w_all):
        return
    mu, sig, w = lobe_gaussians(d_all, w_all, views, active, task.opts.sigma_min,
                                task.opts.sigma_max, task.opts.gaussians, nrm)
    res.mu[i], res.sigma[i], res.w[i] = mu, sig, w
    # over the direct samples (the indirect exits' density is not known) of the views above
    # the horizon (not the raised ones)
    full = active & (views @ nrm > task.min_cos)
    above = full[active]
    res.rel_err[i] = sample_error(dirs[above], wgt[above], q[above], mu, sig, w, full)
    res.fitted_rows[i] = True


__all__ = ["vertex_adjacency", "flood_order", "TransportTask", "IndirectOptions",
           "TransportResult", "run_chunk"]
