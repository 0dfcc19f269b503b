"""The visibility stage: `cfg.visibility` + `cfg.scene` -> artifacts under `<out>/visibility/`
(contract: docs/ARTIFACTS.md). Wang09 §5: trace, SSDF (eq 23), PCA (eq 24), report."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sgpipe.artifacts import visibility as artifacts
from sgpipe.config.schema import to_plain
from sgpipe.errors import BadInput
from sgpipe.io.disk import allocated_memmap
from sgpipe.io.mesh import MeshGeometry, load_scene, object_files
from sgpipe.parallel import chunk_ranges, map_chunks
from sgpipe.stages.base import StageRun, log
from sgpipe.visibility import report as vreport
from sgpipe.visibility.pca import streaming_pca
from sgpipe.visibility.ssdf import downsample_visibility
from sgpipe.visibility.trace import TraceTask, build_scene, trace_chunk, trace_visibility


def run(cfg, out_dir: Path, *, force: bool = False):
    """Run the visibility stage of a validated config (no-op when the section is absent)."""
    if cfg.visibility is None:
        log("[visibility] no 'visibility:' section in the config; nothing to do")
        return None
    if cfg.scene is None or not cfg.scene.objects:
        raise BadInput("the visibility stage needs a `scene:` with at least one object",
                       file=cfg.source, key="scene.objects")
    out_dir = Path(out_dir)
    inputs = [f for o in cfg.scene.objects for f in object_files(o)]
    params = {"visibility": to_plain(cfg.visibility), "scene": to_plain(cfg.scene)}
    with StageRun(cfg, out_dir, "visibility", params=params, inputs=inputs, force=force) as run:
        if run.skipped:
            return run
        # the SSDF memmaps the workers fill: StageRun deletes the folder however the stage ends
        _run(cfg, run, run.scratch_dir())
    return run


def _run(cfg, run: StageRun, tmp: Path) -> None:
    v = cfg.visibility
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    geoms = load_scene(cfg.scene, sphere_subdivisions=v.sphere_subdivisions)
    run.timings["load_s"] = time.perf_counter() - t0
    allp = np.concatenate([g.positions for g in geoms])
    diag = float(np.linalg.norm(allp.max(0) - allp.min(0)))
    offset = v.ray_offset * max(diag, 1e-12)
    max_d = float(np.radians(v.max_distance_deg))
    tri_path = tmp / "triangles.npy"
    np.save(tri_path, np.concatenate([g.triangles for g in geoms]).astype(np.float32))
    d = v.resolution ** 2

    tasks, ssdf_paths = [], []
    for k, g in enumerate(geoms):
        path = tmp / f"ssdf_{k}.f32"
        allocated_memmap(path, np.float32, (len(g.positions), d))
        ssdf_paths.append(path)
        b = g.bitangents
        for s, e in chunk_ranges(len(g.positions), v.chunk_vertices):
            tasks.append(TraceTask(str(tri_path), str(path), len(g.positions), s, e,
                                   g.positions[s:e], g.normals[s:e], g.tangents[s:e], b[s:e],
                                   v.trace_resolution, v.resolution, offset, max_d,
                                   v.sampling, v.adaptive_margin))
    n_vert = sum(len(g.positions) for g in geoms)
    log(f"[visibility] {len(geoms)} objects, {n_vert} vertices, "
        f"{v.trace_resolution}² rays per vertex -> {v.resolution}² SSDF")
    t0 = time.perf_counter()
    results = map_chunks(trace_chunk, tasks, workers=cfg.workers or None,
                         desc="visibility: tracing")
    wall = time.perf_counter() - t0
    rays = sum(r.rays for r in results)
    run.timings.update(trace_wall_s=wall, worker_trace_s=sum(r.trace_s for r in results),
                       worker_ssdf_s=sum(r.ssdf_s for r in results),
                       worker_cpu_s=sum(r.cpu_s for r in results),
                       rays_per_s=rays / max(wall, 1e-9))
    run.report.update(vertices=n_vert, rays=rays, ray_offset=offset, scene_diagonal=diag)

    scene = build_scene(np.load(tri_path))
    summary = {"objects": {}}
    all_rows = []
    for k, g in enumerate(geoms):
        frac = _fractions(tasks, results, str(ssdf_paths[k]), len(g.positions))
        X = np.memmap(ssdf_paths[k], dtype=np.float32, mode="r", shape=(len(g.positions), d))
        t1 = time.perf_counter()
        pca = streaming_pca(X, v.pca_terms, power_iterations=v.power_iterations,
                            seed=cfg.seed + k, block=512)
        run.timings[f"pca_s.{g.name}"] = time.perf_counter() - t1
        obj_report, rows = _write_object(run, cfg, g, pca, X, frac, scene, offset, max_d, k)
        summary["objects"][g.name] = obj_report
        all_rows += rows
        del X
    summary["products_all_objects"] = vreport.summarize_products(all_rows) if all_rows else {}
    run.report["objects"] = {name: {kk: o[kk] for kk in ("vertices", "triangles", "warnings",
                                                          "pca_terms", "fully_visible",
                                                          "fully_occluded")}
                             for name, o in summary["objects"].items()}
    run.report["products"] = summary["products_all_objects"]
    run.write_json(artifacts.REPORT, summary)
    run.timings["main_cpu_s"] = time.process_time() - cpu0


def _fractions(tasks, results, path: str, n: int) -> np.ndarray:
    frac = np.zeros(n)
    for t, r in zip(tasks, results):
        if t.ssdf_path == path:
            frac[r.start:r.stop] = r.visible_fraction
    return frac


def _write_object(run: StageRun, cfg, g: MeshGeometry, pca, X, frac, scene, offset, max_d, k):
    v = cfg.visibility
    res = v.resolution
    name = g.name
    artifacts.write_geometry(run, name, positions=g.positions, normals=g.normals,
                             tangents=g.tangents, bitangents=g.bitangents, faces=g.faces,
                             uvs=g.uvs, has_uvs=g.has_uvs, ray_offset=offset,
                             handedness=g.handedness)
    nterm = pca.basis.shape[0]
    mean = pca.mean.reshape(res, res).astype(np.float32)
    basis = pca.basis.reshape(nterm, res, res).astype(np.float32)
    coeffs = pca.coeffs.astype(np.float32)
    artifacts.write_ssdf_pca(run, name, mean=mean, basis=basis, coeffs=coeffs,
                             explained_variance=pca.explained_variance, resolution=res,
                             trace_resolution=v.trace_resolution, max_distance=max_d)
    for j in [None, *range(nterm)]:
        img, scale = (mean, max_d) if j is None else (basis[j], float(np.abs(basis[j]).max()))
        run.write_png(artifacts.object_file(name, artifacts.eigen_name(j, "png")),
                      vreport.signed_preview(img, scale))

    seed = cfg.seed * 7919 + k
    rep_idx = vreport.pick_vertices(frac, v.report_vertices, seed)
    prev_idx = vreport.pick_vertices(frac, v.preview_vertices, seed + 1)
    b = g.bitangents
    rows = []
    for i in rep_idx:
        rows += vreport.product_accuracy(
            scene, g.positions[i], g.normals[i], g.tangents[i], b[i], offset,
            np.asarray(X[i], np.float64).reshape(res, res), coeffs[i], mean, basis,
            lambdas=v.report_lambdas, directions=v.report_directions,
            samples=v.report_samples, max_distance=max_d, seed=seed + int(i))
    for i in prev_idx:
        vis = trace_visibility(scene, g.positions[i], g.normals[i], g.tangents[i], b[i],
                               v.trace_resolution, offset, sampling=v.sampling,
                               res=v.resolution, margin=v.adaptive_margin)
        raw = np.asarray(X[i], np.float64).reshape(res, res)
        rec = np.clip(pca.reconstruct(int(i)).reshape(res, res), -max_d, max_d)
        run.write_png(artifacts.object_file(name, artifacts.preview_name(int(i))),
                      vreport.vertex_panel(downsample_visibility(vis, res), raw, rec, max_d))
    sub = np.unique(np.linspace(0, len(frac) - 1, min(len(frac), 512)).astype(np.int64))
    pca_err = vreport.pca_error_vs_terms(pca, np.asarray(X[sub]), sub)
    return {
        "vertices": int(len(g.positions)), "triangles": int(len(g.faces)),
        "warnings": g.warnings, "pca_terms": int(nterm),
        "fully_visible": int(np.sum(frac >= 1.0)), "fully_occluded": int(np.sum(frac <= 0.0)),
        "pca_error_vs_terms": pca_err, "report_vertices": [int(i) for i in rep_idx],
        "preview_vertices": [int(i) for i in prev_idx],
        "products": vreport.summarize_products(rows) if rows else {}, "product_samples": rows,
    }, rows
