"""Visibility stage targets (issues 5 and 35), ratios measured in one run:

1. Ray throughput of the stage's per-vertex work vs raw embreex occlusion on the SAME rays
   (same process, interleaved repetitions, best of each): target ≥ 0.70. The gated ratio is
   the stage's tracing step (ray generation + Embree + visibility image); the ratio that also
   counts the SSDF conversion is printed beside it.
2. `sampling: adaptive` against `full` on 48 check vertices (24 per object) of the teapot on
   the tessellated floor, 512² → 128², same process, interleaved per vertex (best of two):
   "equal SSDF error" means max |S_adaptive − S_full| over every texel of the check vertices
   ≤ one trace-texel spacing (√(2π)/512 ≈ 0.0049 rad), the resolution limit of the full
   result itself (its error against a closed-form SSDF, tests/visibility/test_trace.py).
   The per-vertex CPU ratio (trace + SSDF, ~95 % of the `full` stage) is the time target:
   ≤ 60/254 (issue 35: ~254 s on 2 cores with `full`, goal ≤ 60 s).
3. The whole scene (~20.6k vertices) through the real stage with `sampling: adaptive`, 48 PCA
   terms, on every core: its CPU time against full's, extrapolated from the same run (the
   workers' CPU time divided by item 2's per-vertex ratio, plus the same main-process CPU:
   loading, PCA, report), printed beside the absolute goal (≤ 60 s: CPU time / cores, since
   the cores are shared with other work), wall time and load average. Not gated: full's
   stage time is an extrapolation, not a measurement of this run, and the main process's
   CPU time (loading, the PCA's matrix products, the report: the same for both samplings,
   ~14 s on a quiet machine) swings 2–3× with the machine's load, moving this ratio by
   ~0.03.

    .venv/bin/python -m benchmarks visibility
"""

from __future__ import annotations

import json
import os
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RATIO_TARGET = 0.70
FULL_STAGE_S, GOAL_S = 254.0, 60.0          # issue 35: the `full` stage on 2 cores, the goal
STAGE_RATIO_TARGET = GOAL_S / FULL_STAGE_S
ERR_MAX_RAD = float(np.sqrt(2.0 * np.pi) / 512)   # one trace-texel spacing at 512²

CONFIG = """
name: bench_visibility
seed: 0
workers: 0
scene:
  objects:
    - {{name: teapot, mesh: {teapot}}}
    - {{name: floor, mesh: {floor}}}
visibility:
  trace_resolution: 512
  resolution: 128
  pca_terms: 48
  sampling: adaptive
"""


class TreeMemory:
    """Peak RSS / anonymous RSS of this process and its descendants, polled from /proc."""

    def __init__(self, period=0.25):
        self.period = period
        self.peak_rss = self.peak_anon = 0
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)

    @staticmethod
    def _tree(root):
        kids = {}
        for d in os.listdir("/proc"):
            if d.isdigit():
                try:
                    with open(f"/proc/{d}/stat") as f:
                        ppid = int(f.read().rsplit(")", 1)[1].split()[1])
                    kids.setdefault(ppid, []).append(int(d))
                except (OSError, ValueError, IndexError):
                    pass
        out, todo = [], [root]
        while todo:
            p = todo.pop()
            out.append(p)
            todo += kids.get(p, [])
        return out

    @staticmethod
    def _mem(pid):
        rss = anon = 0
        try:
            with open(f"/proc/{pid}/status") as f:
                for line in f:
                    if line.startswith("VmRSS:"):
                        rss = int(line.split()[1]) * 1024
                    elif line.startswith("RssAnon:"):
                        anon = int(line.split()[1]) * 1024
        except OSError:
            pass
        return rss, anon

    def _run(self):
        while not self._stop.is_set():
            tot = [self._mem(p) for p in self._tree(os.getpid())]
            self.peak_rss = max(self.peak_rss, sum(t[0] for t in tot))
            self.peak_anon = max(self.peak_anon, sum(t[1] for t in tot))
            self._stop.wait(self.period)

    def __enter__(self):
        self._t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()


def throughput_ratio(geoms, n_per_object=24, reps=3):
    """(trace-step ratio, trace+SSDF ratio, raw Mray/s) on the same rays, single process."""
    from sgpipe.visibility.ssdf import ssdf_from_visibility
    from sgpipe.visibility.trace import (RayBuffers, build_scene, hemisphere_rays,
                                         trace_visibility_counted)
    tri = np.concatenate([g.triangles for g in geoms]).astype(np.float32)
    scene = build_scene(tri)
    allp = np.concatenate([g.positions for g in geoms])
    off = 1e-4 * float(np.linalg.norm(np.ptp(allp, axis=0)))
    rng = np.random.default_rng(0)
    verts = [(g, int(i)) for g in geoms
             for i in rng.choice(len(g.positions), n_per_object, replace=False)]
    rays = []
    for g, i in verts:
        o, d = hemisphere_rays(g.positions[i], g.normals[i], g.tangents[i], g.bitangents[i],
                               512, off)
        rays.append((o.copy(), d.copy()))
    buf = RayBuffers(512 * 512)
    scene.run(rays[0][0][:1000], rays[0][1][:1000], query="OCCLUDED")   # warm-up / JIT
    trace_visibility_counted(scene, *_frame(verts[0]), 512, off, buffers=buf)
    best_raw = best_trace = best_total = np.inf
    for _ in range(reps):
        t0 = time.process_time()
        for o, d in rays:
            scene.run(o, d, query="OCCLUDED")
        best_raw = min(best_raw, time.process_time() - t0)
        tt = ts = 0.0
        for v in verts:
            t0 = time.process_time()
            vis, _ = trace_visibility_counted(scene, *_frame(v), 512, off, buffers=buf)
            t1 = time.process_time()
            ssdf_from_visibility(vis, 128)
            tt += t1 - t0
            ts += time.process_time() - t1
        best_trace = min(best_trace, tt)
        best_total = min(best_total, tt + ts)
    n_rays = len(verts) * 512 * 512
    return best_raw / best_trace, best_raw / best_total, n_rays / best_raw / 1e6


def adaptive_vs_full(geoms, n_per_object=24, reps=2):
    """Adaptive vs full on the same vertices, interleaved per vertex (best of `reps` CPU
    times each): per-vertex CPU ratio (trace + SSDF), ray fraction, trace texels that
    differ, SSDF |difference| mean and max (radians), full's and adaptive's ms per vertex."""
    from sgpipe.visibility.ssdf import ssdf_from_visibility
    from sgpipe.visibility.trace import RayBuffers, build_scene, trace_visibility_counted
    scene = build_scene(np.concatenate([g.triangles for g in geoms]))
    allp = np.concatenate([g.positions for g in geoms])
    off = 1e-4 * float(np.linalg.norm(np.ptp(allp, axis=0)))
    rng = np.random.default_rng(1)
    verts = [(g, int(i)) for g in geoms
             for i in rng.choice(len(g.positions), n_per_object, replace=False)]
    buf = RayBuffers(512 * 512)
    verts = [_frame(v) for v in verts]                 # (bitangents are computed on access)

    def one(f, sampling):
        t0 = time.process_time()
        vis, m = trace_visibility_counted(scene, *f, 512, off, sampling=sampling, res=128,
                                          buffers=buf)
        s = ssdf_from_visibility(vis, 128)
        return time.process_time() - t0, vis.copy(), m, s

    one(verts[0], "full"), one(verts[0], "adaptive")          # warm-up: caches, JIT
    t_full = t_ad = rays = mism = 0.0
    diffs = []
    for v in verts:
        best_f = best_a = np.inf
        for _ in range(reps):
            tf, vf, _, sf = one(v, "full")
            ta, va, m, sa = one(v, "adaptive")
            best_f, best_a = min(best_f, tf), min(best_a, ta)
        t_full += best_f
        t_ad += best_a
        rays += m / 512 ** 2
        mism += np.mean(vf != va)
        diffs.append(np.abs(sf.astype(np.float64) - sa))
    d = np.stack(diffs)
    n = len(verts)
    return (t_ad / t_full, rays / n, mism / n, float(d.mean()), float(d.max()),
            1e3 * t_full / n, 1e3 * t_ad / n)


def _frame(v):
    g, i = v
    return g.positions[i], g.normals[i], g.tangents[i], g.bitangents[i]


def main() -> int:
    from sgpipe.config import load_config
    from sgpipe.config.sections.scene import ObjectSpec, SceneSection
    from sgpipe.io.mesh import load_scene
    from sgpipe.stages import visibility as stage

    teapot, floor = ROOT / "data_samples/teapot.obj", ROOT / "data_samples/floor.obj"
    geoms = load_scene(SceneSection(objects=[ObjectSpec(name="teapot", mesh=str(teapot)),
                                             ObjectSpec(name="floor", mesh=str(floor))]))
    load0 = os.getloadavg()[0]
    r_trace, r_total, raw_mrays = throughput_ratio(geoms)
    print(f"ray throughput, stage tracing step / raw embreex (same rays): {r_trace:.3f} "
          f"(target >= {RATIO_TARGET}); including SSDF conversion: {r_total:.3f}; "
          f"raw embreex {raw_mrays:.2f} Mray/s per core (load average {load0:.1f} -> "
          f"{os.getloadavg()[0]:.1f})")

    load0 = os.getloadavg()[0]
    ratio, frac, mism, dmean, dmax, ms_full, ms_ad = adaptive_vs_full(geoms)
    print(f"adaptive vs full on 48 vertices (same run): CPU per vertex {ms_ad:.2f} / "
          f"{ms_full:.2f} ms = {ratio:.3f} (target <= {STAGE_RATIO_TARGET:.3f}; trace + "
          f"SSDF, x {FULL_STAGE_S:.0f} s = {ratio * FULL_STAGE_S:.0f} s); "
          f"{100 * frac:.2f}% of the rays; "
          f"{100 * mism:.4f}% of trace texels differ; SSDF |diff| mean {dmean:.2e} rad, max "
          f"{dmax:.2e} rad (target <= {ERR_MAX_RAD:.4f}); load average {load0:.1f} -> "
          f"{os.getloadavg()[0]:.1f}")

    with tempfile.TemporaryDirectory(prefix="bench_vis") as tmp:
        tmp = Path(tmp)
        cfg_path = tmp / "bench.yaml"
        cfg_path.write_text(CONFIG.format(teapot=teapot, floor=floor))
        cfg = load_config(cfg_path)
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        with TreeMemory() as mem:
            stage.run(cfg, tmp / "out", force=True)
        wall = time.perf_counter() - t0
        load1 = os.getloadavg()[0]
        vis_dir = tmp / "out/visibility"
        timings = json.loads((vis_dir / "timings.json").read_text())
        report = json.loads((vis_dir / "report.json").read_text())
    n_vert = sum(o["vertices"] for o in report["objects"].values())
    cores = len(os.sched_getaffinity(0))
    worker, main_cpu = timings["worker_cpu_s"], timings["main_cpu_s"]
    cpu = worker + main_cpu
    full_cpu = worker / ratio + main_cpu
    stage_ratio = cpu / full_cpu
    print(f"{n_vert} vertices, 512² -> 128², 48 terms, sampling=adaptive, {cores} cores: "
          f"CPU {cpu:.0f} s (workers {worker:.0f}, main {main_cpu:.0f}) vs full's "
          f"extrapolated {full_cpu:.0f} s = {stage_ratio:.3f} (not gated; "
          f"{GOAL_S:.0f}/{FULL_STAGE_S:.0f} = {STAGE_RATIO_TARGET:.3f}); "
          f"{cpu / cores:.1f} s on {cores} dedicated cores (full: {full_cpu / cores:.0f} s; "
          f"goal <= {GOAL_S:.0f} s); wall {wall:.1f} s on the shared machine (load average "
          f"{load0:.1f} -> {load1:.1f}); tracing+SSDF phase {timings['trace_wall_s']:.1f} s "
          f"({timings['rays_per_s'] / 1e6:.2f} Mray/s all workers), PCA "
          + ", ".join(f"{k.split('.', 1)[1]} {v:.1f} s" for k, v in timings.items()
                      if k.startswith("pca_s.")))
    print(f"peak memory (process tree): RSS {mem.peak_rss / 2**20:.0f} MiB "
          f"(anonymous {mem.peak_anon / 2**20:.0f} MiB; the rest is the memory-mapped "
          f"SSDF scratch file)")
    for name, o in report["objects"].items():
        errs = ", ".join(f"{m}: {e['rms_rad']:.4f} rad / {100 * e['sign_mismatch']:.2f}%"
                         for m, e in sorted(o["pca_error_vs_terms"].items(),
                                            key=lambda kv: int(kv[0])))
        print(f"  {name}: PCA RMS error / sign mismatch vs terms: {errs}")
    print("  SSDF product vs ray-traced (|err| / f_h(pi/2, lambda), mean / max over "
          "sample vertices x axes): exact f_h on raw SSDF | exact f_h on PCA SSDF | "
          "refit sigmoid on PCA | published sigmoid on PCA:")
    for lam, e in sorted(report["products_all_objects"].items(), key=lambda kv: float(kv[0])):
        print(f"    lambda {lam:>6} (n={e['n']}): " + " | ".join(
            f"{e[k]['mean_abs']:.4f} / {e[k]['max_abs']:.4f}"
            for k in ("err_exact_raw", "err_exact_pca", "err_sigmoid_pca",
                      "err_sigmoid_published_pca")))
    ok = r_trace >= RATIO_TARGET and dmax <= ERR_MAX_RAD and ratio <= STAGE_RATIO_TARGET
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
