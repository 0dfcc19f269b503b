"""Normal-map precompute targets (issue 16): the full vMF pyramid of a 1024² normal map, 4 lobes,
every level, ≤ 20 s on 2 cores (Han07: a 512² map "in under 2 minutes"); the SH pyramid
(l* = 4, 25 coefficients) ≤ 2 s; the engine roughness bake ≤ 1 s.

The map is tools/sample_normalmaps.py's grooves-and-caps pattern at 1024² (no files needed).
Same-run baselines: the unaligned vMF pyramid (pass 1 only: what alignment costs) and the
engine bake (what J lobes cost over one).
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

    from sgpipe.normalmap import pyramid as P
    from sgpipe.normalmap import quality as Q
    from sgpipe.normalmap.sh import ndf_sh_pyramid
    from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    import sample_normalmaps

    normals = sample_normalmaps.grooves_normals(N)
    small = np.ascontiguousarray(normals[:32, :32])
    fit_vmf_pyramid(small, VMFSettings(lobes=LOBES))            # compile outside the timing
    fit_vmf_pyramid(small, VMFSettings(lobes=LOBES, align=False))
    ndf_sh_pyramid(small, SH_ORDER)

    load0 = os.getloadavg()[0]
    pyr, t_vmf, c_vmf = _timed(lambda: fit_vmf_pyramid(normals, VMFSettings(lobes=LOBES)))
    _, t_un, c_un = _timed(lambda: fit_vmf_pyramid(normals, VMFSettings(lobes=LOBES,
                                                                        align=False)))
    gamma, t_sh, c_sh = _timed(lambda: ndf_sh_pyramid(normals, SH_ORDER))

    def bake():
        mean = P.mean_normal_pyramid(normals)
        return mean, [P.engine_roughness(m, 0.1, 1e4) for m in mean]

    (mean, _), t_bake, c_bake = _timed(bake)
    load1 = os.getloadavg()[0]

    # texel-level accuracy at 16× minification (level 4: 16² normals per texel), Blinn–Phong 32
    h = Q.half_vector((45.0, 30.0))
    lev = 4
    truth = Q.truth_levels(normals, 32.0, h, lev + 1)[lev]
    e_vmf = Q.rel_rms(Q.vmf_level(pyr.alpha[lev], pyr.alpha_r[lev], 32.0, h), truth)
    e_tok, e_nrm = (Q.rel_rms(x, truth) for x in Q.baseline_levels(mean[lev], 32.0, h))

    print(f"threads: {get_num_threads()} (cores available: {len(os.sched_getaffinity(0))}); "
          f"load average {load0:.1f} before, {load1:.1f} after")
    print(f"normal map {N}² (grooves + caps), {len(pyr.alpha)} levels")
    print(f"  vMF pyramid, {LOBES} lobes, aligned : {t_vmf:7.2f} s ({c_vmf:.1f} CPU-s; target ≤ "
          f"{TARGET_VMF_S:.0f} s); unaligned {t_un:.2f} s → alignment costs "
          f"{t_vmf / t_un:.2f}×")
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
