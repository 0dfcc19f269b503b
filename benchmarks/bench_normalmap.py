"""Normal-map precompute targets (issue 16): the full vMF pyramid of a 1024² normal map, 4 lobes,
every level, ≤ 20 s on 2 cores (Han07: a 512² map "in under 2 minutes"); the SH pyramid
(l* = 4, 25 coefficients) ≤ 2 s; the engine roughness bake ≤ 1 s.

The map is tools/sample_normalmaps.py's grooves-and-caps pattern at 1024² (no files needed),
filtered as `sgpipe precompute` does by default (`normalmap.bilinear_samples`: levels ≥ 1 from
the bilinear map's sub-samples; the sub-sampling is inside the timings). Same-run baselines:
the unaligned vMF pyramid (pass 1 only: what alignment costs), the texel-centre pyramid
(bilinear_samples 1: what the sub-samples cost) and the engine bake (what J lobes cost over
one).
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

N = 1024
LOBES = 4
SH_ORDER = 4
TARGET_VMF_S = 20.0
TARGET_SH_S = 2.0
TARGET_BAKE_S = 1.0


def _timed(fn):
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t, time.process_time() - c


def main() -> int:
    from numba import get_num_threads

    from sgpipe.config.sections.normalmap import NormalmapSection
    from sgpipe.normalmap import pyramid as P
    from sgpipe.normalmap import quality as Q
    from sgpipe.normalmap.sh import ndf_sh_pyramid
    from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid
    from sgpipe.stages.normalmap import _pyramids, _sh_map

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    import sample_normalmaps

    sub = NormalmapSection().bilinear_samples         # the stage's default
    normals = sample_normalmaps.grooves_normals(N)
    texels = 0.5 * normals + 0.5                        # what the file holds

    def vmf(n, t, settings, s=sub):
        fine, _ = _pyramids(n, t, s, None)
        return fit_vmf_pyramid(n, settings, fine=fine)

    def sh(n, t):
        _, build = _pyramids(n, t, sub, None)
        return build(_sh_map(SH_ORDER), lambda: ndf_sh_pyramid(n, SH_ORDER))

    def bake(n=normals, t=texels):
        _, build = _pyramids(n, t, sub, None)
        mean = build(None, lambda: P.mean_normal_pyramid(n))
        return mean, [P.engine_roughness(m, 0.1, 1e4) for m in mean]

    sn, st = np.ascontiguousarray(normals[:32, :32]), np.ascontiguousarray(texels[:32, :32])
    for s in {sub, 1}:                                  # compile outside the timing
        vmf(sn, st, VMFSettings(lobes=LOBES), s)
        vmf(sn, st, VMFSettings(lobes=LOBES, align=False), s)
    sh(sn, st)
    bake(sn, st)

    load0 = os.getloadavg()[0]
    pyr, t_vmf, c_vmf = _timed(lambda: vmf(normals, texels, VMFSettings(lobes=LOBES)))
    _, t_un, c_un = _timed(lambda: vmf(normals, texels, VMFSettings(lobes=LOBES, align=False)))
    _, t_one, c_one = _timed(lambda: vmf(normals, texels, VMFSettings(lobes=LOBES), 1))
    gamma, t_sh, c_sh = _timed(lambda: sh(normals, texels))

    (mean, _), t_bake, c_bake = _timed(bake)
    load1 = os.getloadavg()[0]

    # texel-level accuracy at 16× minification (level 4: 16² texels each), Blinn–Phong 32,
    # against the mean over the sub-samples the pyramids were built from
    h = Q.half_vector((45.0, 30.0))
    lev = 4
    truth = _pyramids(normals, texels, sub, None)[1](lambda x: Q.truth_samples(x, 32.0, h),
                                                     lambda: Q.truth_levels(normals, 32.0, h,
                                                                            lev + 1))[lev]
    e_vmf = Q.rel_rms(Q.vmf_level(pyr.alpha[lev], pyr.alpha_r[lev], 32.0, h), truth)
    e_tok, e_nrm = (Q.rel_rms(x, truth) for x in Q.baseline_levels(mean[lev], 32.0, h))

    print(f"threads: {get_num_threads()} (cores available: {len(os.sched_getaffinity(0))}); "
          f"load average {load0:.1f} before, {load1:.1f} after")
    print(f"normal map {N}² (grooves + caps), {len(pyr.alpha)} levels, levels ≥ 1 from {sub}×{sub} "
          "sub-samples per texel of the bilinear map (normalmap.bilinear_samples)")
    print(f"  vMF pyramid, {LOBES} lobes, aligned : {t_vmf:7.2f} s ({c_vmf:.1f} CPU-s; target ≤ "
          f"{TARGET_VMF_S:.0f} s); unaligned {t_un:.2f} s → alignment costs "
          f"{t_vmf / t_un:.2f}×; texel centres (bilinear_samples 1) {t_one:.2f} s "
          f"({c_one:.1f} CPU-s) → sub-samples cost {t_vmf / t_one:.2f}×")
    print(f"  SH pyramid, l* = {SH_ORDER} ({(SH_ORDER + 1) ** 2} coeffs) : {t_sh:7.2f} s "
          f"({c_sh:.1f} CPU-s; target ≤ {TARGET_SH_S:.0f} s)")
    print(f"  engine bake (mean, κ, α′)        : {t_bake:7.2f} s ({c_bake:.1f} CPU-s; target ≤ "
          f"{TARGET_BAKE_S:.0f} s); vMF / bake = {t_vmf / t_bake:.0f}×")
    print(f"  level {lev} Blinn–Phong s=32 texel error: vMF {e_vmf:.4f}, Toksvig {e_tok:.4f}, "
          f"normalised MIP {e_nrm:.4f}")
    ok = t_vmf <= TARGET_VMF_S and t_sh <= TARGET_SH_S and t_bake <= TARGET_BAKE_S
    if not ok:
        print("  MISSED: " + ", ".join(f"{k} {v:.2f} s > {t:.0f} s" for k, v, t in (
            ("vMF", t_vmf, TARGET_VMF_S), ("SH", t_sh, TARGET_SH_S),
            ("bake", t_bake, TARGET_BAKE_S)) if v > t))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
