"""Render-stage frame-rate targets at 512² on the CPU OpenCL device (PoCL), for the shading pass
on 2 cores:

- Issue 35 (ISSUE 6's frame), `sg` ≥ 15 frames/s: the shadowed teapot (teapot + floor meshes of
  data_samples/, 1 NDF lobe, 8 environment SG lobes, 48 PCA terms at 32² SSDF resolution, one
  point light). The target is the same-run ratio of sg's CPU time to a fixed reference
  kernel's (`REFERENCE_SRC`: a self-contained scalar loop of exp, log, atan2, sqrt, asin and
  table reads over the same number of work-items, sharing no code with the package, so its
  cost measures the machine, not the kernels) ≤ `SG_REF_RATIO`, which is 15 frames/s (2/15 s
  of CPU on 2 cores) at the reference's CPU time on the development machine; the absolute
  frame rate is printed beside it with the load average. `fis` (N = 40) is timed on the same
  frame for comparison; the Embree G-buffer is reported separately and end to end. The
  visibility arrays are synthetic PCA data of the target size (the kernel's cost does not
  depend on their values).
- Issue 29, textured materials: the same frame with teapot and floor in one glTF metal-rough
  material, uniform and then textured (base colour, metallic-roughness 256² with MIP chains,
  per-pixel roughness-grid lobes): `sg`'s textured frame ≤ 1.3× the uniform one (CPU time,
  same run); `fis` reported beside it.
- Issue 16, `vmf` ≥ 5 frames/s (Han07, 4 lobes, one point light): configs/normalmap_render.yaml
  through the real fit and normal-map precompute stages (the grooves map on the floor plane
  seen at a grazing angle, anisotropic footprint up to 8 taps), and a full-frame variant of it
  (the plane ×8 with the same texel density: every pixel shaded).
- Issue 17, `transport` ≥ 5 frames/s (Green06, 1 Gaussian): green06's speed scene (10 242-vertex
  GGX ball + 10 201-vertex Lambert floor = 20 443 vertices, studio map through the real envmap
  stage), the same with the floor glossy too (all 20 443 vertices carry Gaussians), and that
  under the sky_sun map (its sun: the point set, shaded with SSDF shadows). The Gaussians are
  synthetic mirror lobes in the stage's artifact format (benchmarks/_scenes.py
  `write_mirror_transport`), the SSDF data synthetic of the visibility stage's size: fitting
  and tracing 20k vertices take minutes; the kernel's cost depends on the frame, the view set,
  which views carry weight and the data's sizes, not on the fitted values.

Frame time = the minimum over warm launches of wall-clock (upload-free: the G-buffer stays on
the device, as a rasteriser's would; the kernel build and a first launch happen before the
timing). On a shared machine wall-clock also counts other processes' time; the report therefore
adds the process CPU time of the launch (all PoCL threads) and the 2-core estimate 2 / cpu_s,
and each absolute frame-rate target is judged on the better of the two, on every case listed;
sg's by its ratio to the reference kernel, whose CPU time is taken before and after the frames
(the faster of the two). (The equal-quality sg-vs-reference ratio is
benchmarks/bench_equal_quality.py.)

Where the sg frame's time goes (perf on the kernel's shared object; benchmarks/HISTORY.md has
the numbers): PoCL's CPU device runs each work-item as scalar code (its work-item loop holds
data-dependent inner loops, which LLVM's loop vectoriser leaves alone), so the kernels get
their vector width from their own data: the environment's 8 SG lights go through in float8
lanes (kernels/include/env_diffuse.h), the SSDF's PCA terms in 16-float vectors (ssdf.h). The
rest is the specular sub-lobes (3 per NDF lobe: M_o, the visible part, the clipped lobe and
its SSDF gradient, two B-spline Γ_L levels and their Hermite) and the SSDF decodes.
`python -m benchmarks render`; main() returns 0 when every target is met.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

FPS_TARGET = 5.0
#: issue 35: the sg frame's frame rate, judged as the same-run ratio SG_REF_RATIO
SG_FPS_TARGET = 15.0
#: sg CPU / reference kernel CPU, same run: (2 / 15 s) / 0.140 s, the reference's CPU time on
#: the development machine (2 AVX-512 cores, PoCL 3.1, benchmarks/HISTORY.md 2026-11-30)
SG_REF_RATIO = 0.95
#: issue 29: a frame whose materials come from textures per pixel costs at most this many
#: times the same frame with the uniform material
TEXTURED_RATIO = 1.3
REPEATS = 5


def _time(fn, repeats):
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return min(wall), min(cpu)


def _shade_timing(r, method, fdev, repeats=REPEATS) -> dict:
    """Build + warm-up launch, then `repeats` timed launches of `method` on the uploaded frame."""
    t0 = time.perf_counter()
    r.shade(method, fdev)
    warm = time.perf_counter() - t0
    wall, cpu = _time(lambda: r.shade(method, fdev), repeats)
    return {"pixels": int(fdev["n"]), "wall_s": wall, "cpu_s": cpu, "fps": 1.0 / wall,
            "fps_2core_estimate": 2.0 / cpu, "first_launch_s": warm,
            "build_s": r.timings.get(f"{method}_build_s", 0.0)}


#: The reference kernel of the sg ratio: per work-item a fixed scalar mix of the library's
#: transcendental calls and table reads (a 256 KiB table, as a kernel's lookups into its
#: scene data), compiled with the package's options; sharing no code with the package, its
#: time follows the machine and its load, not the kernels. Never change it: the ratio's
#: history depends on it.
REFERENCE_SRC = r"""
__kernel void bench_reference(const int n, __global const float *tab, __global float *out) {
    int i = get_global_id(0);
    if (i >= n) return;
    uint h = (uint)i * 2654435761u;
    float x = 0.1f + (float)(i & 1023) * 1e-3f, acc = 0.0f;
    for (int k = 0; k < 16; ++k) {
        h = h * 1664525u + 1013904223u;
        float t = tab[(h >> 9) & 65535];
        acc += exp(-x * t) + log(1.0f + x + t) + atan2(t, x + 0.5f) + sqrt(x + t)
               + asin(0.5f * t);
        x = x * 0.75f + 0.25f * t;
    }
    out[i] = acc;
}
"""


def bench_reference(n: int, repeats=REPEATS) -> dict:
    """The reference kernel over `n` work-items (work-groups of the renderer's size)."""
    import numpy as np
    import pyopencl as cl
    from sgpipe.render import opencl
    from sgpipe.render.renderer import LOCAL_SIZE
    ctx, queue = opencl.get_context()
    kern = cl.Kernel(cl.Program(ctx, REFERENCE_SRC).build(
        options=["-cl-fast-relaxed-math"]), "bench_reference")
    tab = opencl.to_device(ctx, np.random.default_rng(0).random(65536).astype(np.float32))
    out = opencl.empty_device(ctx, 4 * n)

    def launch():
        kern(queue, (-(-n // LOCAL_SIZE) * LOCAL_SIZE,), (LOCAL_SIZE,), np.int32(n), tab, out)
        queue.finish()
    launch()
    wall, cpu = _time(launch, repeats)
    return {"wall_s": wall, "cpu_s": cpu}


def bench_fps(repeats=REPEATS) -> dict:
    """`sg` and `fis` on the teapot frame, the G-buffer and end to end."""
    from benchmarks._scenes import teapot_scene
    from sgpipe.render.renderer import Frame
    from sgpipe.scene.gbuffer import Tracer
    r, objs, cam = teapot_scene()
    t0 = time.perf_counter()
    o, d = cam.rays()
    tracer = Tracer(objs)
    gb = tracer.trace(o, d)
    fr = Frame.from_gbuffer(gb)
    t_gb = time.perf_counter() - t0
    fdev = r.upload_frame(fr)
    out = {"pixels": int(len(fr.index)), "gbuffer_s": t_gb}
    out["reference"] = bench_reference(out["pixels"], repeats)
    for method in ("sg", "fis"):     # gmm needs fitted view-GMM tables: see the demo's timings
        out[method] = _shade_timing(r, method, fdev, repeats)
    # the reference again after the frames: the ratio takes the faster of its two timings
    again = bench_reference(out["pixels"], repeats)
    out["reference"]["cpu_s"] = min(out["reference"]["cpu_s"], again["cpu_s"])
    out["sg_ratio"] = out["sg"]["cpu_s"] / out["reference"]["cpu_s"]

    def e2e():
        o, d = cam.rays()
        r.shade("sg", Frame.from_gbuffer(tracer.trace(o, d)))
    out["end_to_end_s"], out["end_to_end_cpu_s"] = _time(e2e, 2)
    return out


def bench_textured(repeats=REPEATS) -> dict:
    """`sg` and `fis` on the teapot frame with both objects in one glTF metal-rough material,
    uniform, then textured (per-pixel base colour, metallic and roughness: the pixel's record
    and interpolated roughness-grid lobes), same run; footprints on in both."""
    from benchmarks._scenes import teapot_scene
    from sgpipe.render.renderer import Frame
    from sgpipe.scene.footprint import uv_derivatives
    from sgpipe.scene.gbuffer import Tracer
    out = {}
    for case in ("uniform", "textured"):
        r, objs, cam = teapot_scene(gltf=case)
        gb = Tracer(objs).trace(*cam.rays())
        fr = Frame.from_gbuffer(gb)
        fr.duv = uv_derivatives(cam, gb).reshape(-1, 4)[fr.index]
        fdev = r.upload_frame(fr)
        out[case] = {m: _shade_timing(r, m, fdev, repeats) for m in ("sg", "fis")}
    for m in ("sg", "fis"):
        out[f"{m}_ratio"] = out["textured"][m]["cpu_s"] / out["uniform"][m]["cpu_s"]
    return out


def bench_vmf(work: Path, repeats=REPEATS) -> dict:
    """Issue 16: `vmf` on configs/normalmap_render.yaml at 512² and its full-frame variant."""
    from benchmarks._scenes import NORMALMAP_FULL_FRAME, normalmap_scene
    out = {}
    for case, extra in (("normalmap_render.yaml", []),
                        ("full frame (plane ×8)", NORMALMAP_FULL_FRAME)):
        t0 = time.perf_counter()
        r, fr = normalmap_scene(work / "normalmap", extra=extra)
        setup = time.perf_counter() - t0
        out[case] = {**_shade_timing(r, "vmf", r.upload_frame(fr), repeats), "setup_s": setup}
    return out


#: transport cases: (label, floor glossy, config overrides)
TRANSPORT_CASES = (("green06 speed scene", False, []),
                   ("every vertex glossy", True, []),
                   ("every vertex glossy, sky_sun", True,
                    ["envmap.environment=../data_samples/sky_sun.exr"]))


def bench_transport(work: Path, repeats=REPEATS) -> dict:
    """Issue 17: `transport` on green06's 20 443-vertex speed scene at 512² under the studio map,
    floor Lambert (as green06) and floor glossy, and the glossy one under sky_sun (its sun is
    the envmap stage's point set: SSDF-shadowed delta lights in the diffuse part)."""
    from benchmarks._scenes import transport_scene
    out = {}
    for case, glossy, extra in TRANSPORT_CASES:
        t0 = time.perf_counter()
        r, fr, nv = transport_scene(work / "transport", glossy_floor=glossy, extra=extra)
        setup = time.perf_counter() - t0
        out[case] = {**_shade_timing(r, "transport", r.upload_frame(fr), repeats),
                     "setup_s": setup, "vertices": nv}
    return out


def _line(label: str, x: dict) -> str:
    return (f"{label}: {x['pixels']} shaded pixels: {x['wall_s'] * 1e3:.0f} ms wall = "
            f"{x['fps']:.2f} frames/s; CPU {x['cpu_s'] * 1e3:.0f} ms → 2-core estimate "
            f"{x['fps_2core_estimate']:.2f} frames/s (build {x['build_s']:.2f} s)")


def _best(x: dict) -> float:
    return max(x["fps"], x["fps_2core_estimate"])


def main() -> int:
    import os
    from sgpipe.render import opencl
    print(f"device: {opencl.device_name()}, load average {os.getloadavg()[0]:.1f}", flush=True)
    f = bench_fps()
    for m in ("sg", "fis"):
        print(_line(f"{m:>3} 512² teapot", f[m]))
    print(f"G-buffer (Embree + compaction): {f['gbuffer_s'] * 1e3:.0f} ms; end to end (rays + "
          f"G-buffer + upload + sg): {f['end_to_end_s'] * 1e3:.0f} ms", flush=True)
    f["textured"] = tx = bench_textured()
    for case in ("uniform", "textured"):
        for m in ("sg", "fis"):
            print(_line(f"{m:>3} 512² teapot, glTF material {case}", tx[case][m]))
    ok_tx = tx["sg_ratio"] <= TEXTURED_RATIO
    print(f"target issue 29: textured / uniform sg frame ≤ {TEXTURED_RATIO} (CPU time, same "
          f"run): {'met' if ok_tx else 'MISSED'} ({tx['sg_ratio']:.3f}; fis "
          f"{tx['fis_ratio']:.3f})", flush=True)
    with tempfile.TemporaryDirectory(prefix="sgpipe-bench-render-") as tmp:
        f["vmf"] = bench_vmf(Path(tmp))
        for case, x in f["vmf"].items():
            print(_line(f"vmf 512² {case}", x) + f"; setup {x['setup_s']:.1f} s", flush=True)
        f["transport"] = bench_transport(Path(tmp))
        for case, x in f["transport"].items():
            print(_line(f"transport 512² {case} ({x['vertices']} vertices)", x)
                  + f"; setup {x['setup_s']:.1f} s", flush=True)
    ok_sg = f["sg_ratio"] <= SG_REF_RATIO
    print(f"target issue 35: sg ≥ {SG_FPS_TARGET:g} frames/s as sg / reference kernel CPU ≤ "
          f"{SG_REF_RATIO} (same run): {'met' if ok_sg else 'MISSED'} ({f['sg_ratio']:.3f}; "
          f"reference {f['reference']['cpu_s'] * 1e3:.0f} ms CPU); absolute {_best(f['sg']):.2f} "
          f"frames/s ({'met' if _best(f['sg']) >= SG_FPS_TARGET else 'missed'}), "
          f"load average {os.getloadavg()[0]:.1f}")
    checks = [("issue 16: vmf", list(f["vmf"].values())),
              ("issue 17: transport", list(f["transport"].values()))]
    ok = ok_tx and ok_sg
    for name, cases in checks:
        best = min(_best(x) for x in cases)      # the slowest case must meet it
        ok &= best >= FPS_TARGET
        print(f"target {name} ≥ {FPS_TARGET} frames/s: "
              f"{'met' if best >= FPS_TARGET else 'MISSED'} ({best:.2f}), load average "
              f"{os.getloadavg()[0]:.1f}")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    path = Path(tempfile.gettempdir()) / "sgpipe-bench-render.json"
    path.write_text(json.dumps(f, indent=2, default=float))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
