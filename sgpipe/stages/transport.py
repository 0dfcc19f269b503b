"""The transport stage: `cfg.transport` + `cfg.scene` + `cfg.fit.materials` -> artifacts under
`<out>/transport/` (sgpipe.artifacts.transport). Green06 §4: glossy transport per vertex and view
(direct, plus the indirect T^IG of eq 5 with `transport.indirect`), fitted with Gaussians
(eq 6), stored compactly; the diffuse part as SH PRT (shadowed, plus interreflected)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sgpipe.artifacts import transport as artifacts
from sgpipe.brdf import REGISTRY, BRDFParamError, brdf_from_spec, frame_rotation
from sgpipe.config.schema import to_plain
from sgpipe.core.sphere import turn_frame
from sgpipe.errors import BadInput
from sgpipe.io.mesh import load_scene, object_files
from sgpipe.parallel import map_chunks, progress
from sgpipe.stages.base import StageRun, log
from sgpipe.transport import compact
from sgpipe.transport.chunk import (IndirectOptions, TransportTask, flood_order, run_chunk,
                                    vertex_adjacency)
from sgpipe.transport.fit import FitOptions
from sgpipe.transport.interp import evaluate
from sgpipe.transport.sampling import PathScene, light_cube


def run(cfg, out_dir: Path, *, force: bool = False):
    """Run the transport stage of a validated config (no-op when the section is absent)."""
    if cfg.transport is None:
        log("[transport] no 'transport:' section in the config; nothing to do")
        return None
    if cfg.scene is None or not cfg.scene.objects:
        raise BadInput("the transport stage needs a `scene:` with at least one object",
                       file=cfg.source, key="scene.objects")
    t = cfg.transport
    geoms = load_scene(cfg.scene, sphere_subdivisions=t.sphere_subdivisions)
    _check_meshes(cfg, geoms)
    materials = [_material(cfg, i, o.material) for i, o in enumerate(cfg.scene.objects)]
    # the textures are decoded with the other bad-input checks, before the stage starts
    vmats = _vertex_materials(cfg, geoms)
    inputs = [f for o in cfg.scene.objects for f in object_files(o)]
    inputs += [m.merl_file for m in (cfg.fit.materials if cfg.fit else []) if m.merl_file]
    params = {"transport": to_plain(t), "scene": to_plain(cfg.scene),
              "materials": [to_plain(m[0]) for m in materials]}
    with StageRun(cfg, out_dir, "transport", params=params, inputs=inputs, force=force) as run:
        if run.skipped:
            return run
        _run(cfg, run, run.scratch_dir(), geoms, materials, vmats)
    return run


def _vertex_materials(cfg, geoms) -> list:
    """Per object its per-vertex materials (transport.vertex_materials on a textured,
    isotropic gltf_pbr material: vertex_material.VertexMaterials), else None."""
    if not cfg.transport.vertex_materials:
        return [None] * len(geoms)
    from sgpipe.render.setup import gltf_textures
    from sgpipe.transport.vertex_material import vertex_materials
    assets: dict = {}
    return [vertex_materials(gltf_textures(cfg, o, assets), g)
            for o, g in zip(cfg.scene.objects, geoms)]


def _check_meshes(cfg, geoms) -> None:
    """Bad input for Green06's per-vertex transport: repaired meshes are refused, not fitted."""
    t = cfg.transport
    for i, (o, g) in enumerate(zip(cfg.scene.objects, geoms)):
        key = f"scene.objects.{i}.mesh" if o.mesh is not None else f"scene.objects.{i}"
        where = o.mesh if o.mesh is not None else cfg.source
        if g.warnings.get("vertices_with_cancelling_normals") or \
                g.warnings.get("invalid_file_normals_recomputed"):
            n = (g.warnings.get("vertices_with_cancelling_normals", 0)
                 + g.warnings.get("invalid_file_normals_recomputed", 0))
            raise BadInput(f"{n} vertices have no usable normal (transport is fitted per vertex "
                           "about its normal)", file=where, key=key)
        if g.warnings.get("degenerate_triangles_removed"):
            raise BadInput(f"{g.warnings['degenerate_triangles_removed']} degenerate (zero-area) "
                           "triangles", file=where, key=key)
        if len(g.positions) > t.vertex_limit:
            raise BadInput(f"{len(g.positions)} vertices exceed transport.vertex_limit = "
                           f"{t.vertex_limit}", file=where, key="transport.vertex_limit")


def _material(cfg, index: int, name: str):
    """(spec, model, params for the workers, diffuse f_d RGB) of an object's material."""
    specs = {m.name: (n, m) for n, m in enumerate(cfg.fit.materials)} if cfg.fit else {}
    if name not in specs:
        raise BadInput(f"material {name!r} is not in fit.materials (the transport stage takes "
                       "its BRDFs from there)", file=cfg.source,
                       key=f"scene.objects.{index}.material")
    n, spec = specs[name]
    base = f"fit.materials.{n}"
    if spec.model not in REGISTRY:
        raise BadInput(f"unknown BRDF model {spec.model!r}", file=cfg.source, key=f"{base}.model")
    try:
        brdf = brdf_from_spec(spec)
    except BRDFParamError as e:
        key = f"{base}.merl_file" if e.param == "merl_file" else f"{base}.params.{e.param}"
        raise BadInput(e.message, file=cfg.source, key=key) from None
    except BadInput as e:
        raise BadInput(e.message, file=e.file, key=f"{base}.merl_file") from None
    params = dict(spec.params or {})
    if spec.merl_file:
        params["merl_file"] = str(spec.merl_file)
    z = np.array([0.0, 0.0, 1.0])
    # the view-independent part: f_d at normal incidence (exact for Lambert)
    return spec, spec.model, params, brdf.diffuse(z, z)


def _run(cfg, run: StageRun, tmp: Path, geoms, materials, vmats) -> None:
    t = cfg.transport
    allp = np.concatenate([g.positions for g in geoms])
    diag = float(np.linalg.norm(allp.max(0) - allp.min(0)))
    offset = t.ray_offset * max(diag, 1e-12)
    tri_path = tmp / "triangles.npy"
    np.save(tri_path, np.concatenate([g.triangles for g in geoms]).astype(np.float32))
    opts = FitOptions(gaussians=t.gaussians, alpha=t.alpha, beta=t.beta, gamma=t.gamma,
                      delta=t.delta, max_iter=t.max_iterations, ftol=t.tolerance,
                      sigma_min=float(np.radians(t.sigma_min_resolved_deg())),
                      sigma_max=float(np.radians(t.sigma_max_deg)))
    # indirect paths run through every object of the scene with its own BRDF
    paths = (PathScene.from_geometry(geoms, [(m[1], m[2]) for m in materials])
             if t.indirect else None)
    tasks, owner = [], []
    for k, (g, (_, model, params, _)) in enumerate(zip(geoms, materials)):
        ind = None if paths is None else IndirectOptions(
            paths, k, int(cfg.seed), t.indirect_bounces, t.indirect_paths,
            t.indirect_transfer_paths)
        adj = vertex_adjacency(g.faces, len(g.positions))
        order = flood_order(adj)
        # the anisotropy direction (gltf_pbr `anisotropy_rotation`): the vertex frames turned
        # about the normal, as the kernels' pixel_init turns the pixel's
        turn = frame_rotation(materials[k][0])
        if g.handedness is not None:       # towards w · n × t
            turn = turn * np.asarray(g.handedness, float)
        tng, b = turn_frame(g.tangents, g.bitangents, turn)
        for s in range(0, len(order), t.chunk_vertices):
            o = order[s:s + t.chunk_vertices]
            tasks.append(TransportTask(str(tri_path), o, g.positions[o], g.normals[o],
                                       tng[o], b[o], [adj[i] for i in o], model, params,
                                       t.cube_resolution, offset, opts,
                                       float(np.sin(np.radians(t.min_view_elevation_deg))),
                                       ind, t.sampling, t.lobe_samples,
                                       vertex_materials=None if vmats[k] is None
                                       else vmats[k].rows(o)))
            owner.append(k)
    n_vert = sum(len(g.positions) for g in geoms)
    log(f"[transport] {len(geoms)} objects, {n_vert} vertices × 92 views, "
        f"{t.gaussians} Gaussian(s), "
        + (f"{t.lobe_samples} lobe samples per view, " if t.sampling == "lobe" else "")
        + f"light cube 6×{t.cube_resolution}²"
        + "".join(f", {g.name}: per-vertex material" for g, v in zip(geoms, vmats)
                  if v is not None)
        + (f", indirect ({t.indirect_bounces} bounces, {t.indirect_paths} paths per view, "
           f"{t.indirect_transfer_paths} per occluded texel)" if t.indirect else ""))
    t0 = time.perf_counter()
    desc = "transport: sampling" + (" + indirect paths" if t.indirect else "") + " + fitting"
    if t.flood_fill == "mesh" and t.sampling == "cube":
        results = _mesh_flood_fill(tasks, owner, desc)
    else:
        results = map_chunks(run_chunk, tasks, workers=cfg.workers or None, desc=desc)
    wall = time.perf_counter() - t0
    cpu = sum(r.cpu_s for r in results)
    # Gaussians of vertices that have glossy transport (diffuse-only vertices are skipped)
    fitted = sum(r.fitted for r in results) * 92 * t.gaussians
    run.timings.update(wall_s=wall, worker_cpu_s=cpu,
                       worker_transport_s=sum(r.transport_s for r in results),
                       worker_fit_s=sum(r.fit_s for r in results),
                       gaussians_per_cpu_s=fitted / max(cpu, 1e-9))
    objects = {}
    for k, (g, mat) in enumerate(zip(geoms, materials)):
        objects[g.name] = _write_object(run, cfg, g, mat,
                                        [r for r, o in zip(results, owner) if o == k],
                                        vmats[k])
    for name, o in objects.items():
        parts = [f"{c} {v['mean']:.3f} ({v['vertices']})"
                 for c, v in o["fit_rel_err_by_class"].items() if v["vertices"]]
        log(f"[transport] {name}: mean relative fit error by visibility: "
            f"{', '.join(parts) or 'no fitted vertex'}")
    run.report.update(vertices=n_vert, gaussians_fitted=fitted, objects=objects)
    run.write_json(artifacts.REPORT, {"objects": objects})


def _mesh_flood_fill(tasks, owner, desc: str) -> list:
    """transport.flood_fill: mesh — the chunks of each object one after another, each given
    the fits of its vertices' neighbours that earlier chunks fitted (`TransportTask.prior`), so
    the flood fill runs over the whole mesh as Green06 §4.2 has it."""
    results, fitted = [], {}
    bar = progress(len(tasks), desc + " (one flood fill per mesh)")
    for task, k in zip(tasks, owner):
        fits = fitted.setdefault(k, {})
        want = {int(u) for nb in task.neighbours for u in nb} - set(map(int, task.order))
        task.prior = {u: fits[u] for u in sorted(want) if u in fits}
        r = run_chunk(task)
        for row in np.flatnonzero(r.fitted_rows):
            fits[int(r.order[row])] = (r.mu[row], r.sigma[row], r.w[row])
        results.append(r)
        if bar:
            bar.update(1)
    if bar:
        bar.render_finish()
    return results


def _write_object(run, cfg, g, mat, results, vmat=None) -> dict:
    t = cfg.transport
    n, K = len(g.positions), t.gaussians
    mu, sigma = np.zeros((n, 92, K, 3)), np.zeros((n, 92, K))
    w, sh, sh_ind = np.zeros((n, 92, K, 3)), np.zeros((n, 25)), np.zeros((n, 25, 3))
    err, iters, vis = np.zeros(n), np.zeros(n, np.int64), np.zeros(n)
    lobe = t.sampling == "lobe"
    if lobe:
        mu_o, sigma_o, w_o = np.zeros_like(mu), np.zeros_like(sigma), np.zeros_like(w)
    for r in results:
        mu[r.order], sigma[r.order], w[r.order] = r.mu, r.sigma, r.w
        if lobe:
            mu_o[r.order], sigma_o[r.order], w_o[r.order] = r.mu_open, r.sigma_open, r.w_open
        sh[r.order], err[r.order], iters[r.order], vis[r.order] = r.sh, r.rel_err, r.iters, \
            r.visible
        sh_ind[r.order] = r.sh_indirect
    lo, hi = np.radians(t.sigma_min_resolved_deg()), np.radians(t.sigma_max_deg)
    packed = compact.encode(mu, sigma, w, lo, hi)
    if lobe:
        # the unshadowed set is stored only where it differs (an occluder cuts the vertex's
        # lobes); elsewhere the reader takes the shadowed set (`open_same`)
        same = ((mu_o == mu).all(axis=(1, 2, 3)) & (sigma_o == sigma).all(axis=(1, 2))
                & (w_o == w).all(axis=(1, 2, 3)))
        w_o = np.where(same[:, None, None, None], 0.0, w_o)
        packed.update({f"{artifacts.OPEN}{k}": v
                       for k, v in compact.encode(mu_o, sigma_o, w_o, lo, hi).items()})
        packed[f"{artifacts.OPEN}same"] = same.astype(np.uint8)
    artifacts.write_object(run, g.name, packed=packed, cube_resolution=t.cube_resolution,
                           gaussians=K, sh=sh, sh_indirect=sh_ind, diffuse_rgb=mat[3],
                           positions=g.positions, normals=g.normals, faces=g.faces)
    if vmat is not None:
        artifacts.write_vertex_materials(run, g.name, kd=vmat.kd, f0=vmat.f0,
                                         roughness=vmat.roughness)
    nbytes, paper = compact.nbytes(packed), compact.paper_bytes(n, K)
    open_bytes = compact.nbytes({k: v for k, v in packed.items()
                                 if k.startswith(artifacts.OPEN)})
    return {
        "vertices": int(n), "vertex_materials": vmat is not None,
        "compact_bytes": nbytes, "paper_bytes": paper,
        "compact_over_paper": nbytes / paper,
        # of compact_bytes, the unshadowed Gaussians (sampling: lobe; the vertices an
        # occluder reaches)
        "open_bytes": open_bytes,
        "compact_vs_full_rel_err": _compact_error(mu, sigma, w, lo, hi, t),
        "fit_rel_err_mean": float(err.mean()), "fit_rel_err_p95": float(np.percentile(err, 95)),
        "lm_iterations_mean": float(iters.mean()),
        "visible_fraction_mean": float(vis.mean()),
        "fit_rel_err_by_class": error_by_class(err, vis, np.any(w != 0, axis=(1, 2, 3))),
        # |indirect| / |shadowed| of the SH transfer (L2 over vertices, coefficients, RGB)
        "sh_indirect_over_shadowed": float(np.linalg.norm(sh_ind)
                                           / max(np.sqrt(3) * np.linalg.norm(sh), 1e-30)),
    }


#: Vertex classes of the fit-error report by the visible fraction of the vertex's upper
#: hemisphere: open (only the horizon cuts its lobes), clipped (a rim or a neighbour cuts part
#: of its sky), occluded (most of it hidden).
CLASSES = (("open", 0.98, 1.01), ("clipped", 0.5, 0.98), ("occluded", -0.01, 0.5))


def error_by_class(err, visible, fitted) -> dict:
    """{class: {vertices, mean, p95}} of the fitted vertices' relative fit error, classed by
    visible fraction (CLASSES): where one Gaussian per view is not enough shows here."""
    out = {}
    for name, lo, hi in CLASSES:
        sel = fitted & (visible >= lo) & (visible < hi)
        e = err[sel]
        out[name] = {"vertices": int(sel.sum()),
                     "mean": float(e.mean()) if e.size else None,
                     "p95": float(np.percentile(e, 95)) if e.size else None}
    return out


def _compact_error(mu, sigma, w, lo, hi, t) -> float:
    """Root mean square over `report_vertices` evenly spaced vertices of the relative L2 error,
    over the light texels and all the vertex's weighted views, of the compact Gaussians against
    the full float64 fit. (Pooled per vertex: views in shadow have weights of 1e-10 of the
    vertex's, whose own relative error is meaningless.)"""
    if t.report_vertices == 0:
        return 0.0
    n = len(mu)
    sub = np.unique(np.linspace(0, n - 1, min(n, t.report_vertices)).astype(np.int64))
    mu2, s2, w2, _ = compact.decode(compact.encode(mu[sub], sigma[sub], w[sub], lo, hi))
    cube = light_cube(t.cube_resolution)
    errs = []
    for i in range(len(sub)):
        num = den = 0.0
        for v in np.flatnonzero(np.any(w[sub[i]] != 0, axis=(1, 2))):
            a = evaluate(cube.dirs, mu[sub[i], v], sigma[sub[i], v], w[sub[i], v])
            b = evaluate(cube.dirs, mu2[i, v], s2[i, v], w2[i, v])
            num += float(((a - b) ** 2).sum(-1) @ cube.omega)
            den += float((a ** 2).sum(-1) @ cube.omega)
        if den > 0:
            errs.append(num / den)
    return float(np.sqrt(np.mean(errs))) if errs else 0.0
