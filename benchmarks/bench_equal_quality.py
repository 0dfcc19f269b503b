"""Equal-quality speed: time for `sg` vs time for `reference` to reach the same PSNR against a
converged reference (ISSUE 6 target: ratio ≥ 100×).

Scene: the figures' sphere (Ward α = 0.1, kd = 0, ks = 1) under data_samples/studio.exr.
1. `sg` through the real stages (fit → precompute → render) in a temporary folder: its image
   and its warm per-frame time `sg_s` (render timings.json).
2. A converged reference R* (CONVERGED_SPP, seed 1) with per-pixel standard errors σ*.
3. The reference's cost per spp: the slope of wall time between two renders (SPP_A, SPP_B,
   seed 2; the slope drops fixed costs such as primary rays and process start-up), and its
   mean squared error at SPP_B, mean σ_B² (MC variance ∝ 1/spp; checked against the measured
   MSE to R*, minus R*'s own variance).
4. sg's true squared error: MSE(sg, R*) − mean σ*² (R* = truth + noise). The reference needs
   n = SPP_B · mean σ_B² / that error samples per pixel for the same PSNR; its time is n × slope.
main() prints the numbers and returns 0 when time_ref / time_sg ≥ 100.
Measured (2 shared cores): sg with Wang09's isotropic warp, C* ⊗ and the bilinear Γ_L path
19.3 dB (11–22×); with the anisotropic warp (3 sub-lobes), the Gaussian cosine product and the
accurate Γ_L path (sg_shade.cl) 31.7 dB true-error PSNR, 9.6 ms/frame, 160–290×. What remains
is mostly grazing reflections (n·v ≈ 0.2–0.35, −12 %): the warped lobe bends there.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

GOAL = 100.0
SIZE = 96
CONVERGED_SPP = 2048
SPP_A, SPP_B = 16, 64


def _sg_through_stages(cfg_for, out: Path):
    """(image, seconds per frame) of `sg`, or (None, reason)."""
    from sgpipe.experiments.figures import _run_stage
    from sgpipe.io import read_exr
    cfg = cfg_for(["sg"])
    for stage in ("fit", "precompute", "render"):
        err = _run_stage(stage, cfg, out)
        if err is not None:
            return None, f"{stage} stage: {err}"
    t = json.loads((out / "render" / "timings.json").read_text())
    if "sg_s" not in t:
        return None, "render stage wrote no sg_s timing"
    return read_exr(out / "render" / "sg.exr")[..., :3], float(t["sg_s"])


def main() -> int:
    from sgpipe.experiments.figures import DATA, build_config
    from sgpipe.metrics import PSNR_PEAK, mse, psnr
    from sgpipe.parallel import default_workers
    from sgpipe.stages.render import reference_from_config

    mats = [{"name": "ward", "model": "ward", "params": {"alpha": 0.1, "kd": 0.0, "ks": 1.0}}]

    def cfg_for(methods, spp=CONVERGED_SPP, seed=1):
        # sg's time: the minimum of 10 warm launches (a 96² frame takes ~10 ms: single
        # launches are at the mercy of the scheduler on a shared machine). Shading quality at
        # equal cost: both sample the pixel centre (a box-filtered truth would charge sg's one
        # ray per pixel for silhouette aliasing, which supersampling, not shading, fixes).
        return build_config(DATA / "studio.exr", mats, "ward", methods, size=SIZE, spp=spp,
                            seed=seed, workers=default_workers(),
                            render_extra={"timing_repeats": 10,
                                          "pixel_filter": {"type": "center"}})

    with tempfile.TemporaryDirectory(prefix="sgpipe-bench-eq-") as tmp:
        sg_img, sg_s = _sg_through_stages(cfg_for, Path(tmp))
    if sg_img is None:
        print(f"sg method not available ({sg_s}); the equal-quality ratio cannot be measured")
        return 1
    t0 = time.perf_counter()
    conv = reference_from_config(cfg_for(["reference"]))
    print(f"converged reference: {CONVERGED_SPP} spp in {time.perf_counter() - t0:.1f} s")
    var_conv = float(np.mean(conv.stderr.astype(np.float64) ** 2))
    runs = {n: reference_from_config(cfg_for(["reference"], spp=n, seed=2)) for n in (SPP_A, SPP_B)}
    slope = (runs[SPP_B].seconds - runs[SPP_A].seconds) / (SPP_B - SPP_A)
    if slope <= 0:  # timing noise on a loaded machine: fall back to the mean cost per spp
        slope = runs[SPP_B].seconds / SPP_B
    var_b = float(np.mean(runs[SPP_B].stderr.astype(np.float64) ** 2))
    measured_b = mse(runs[SPP_B].image, conv.image) - var_conv
    err_sg = mse(sg_img, conv.image) - var_conv
    floor = err_sg <= var_conv
    if floor:
        err_sg = var_conv  # sg is within the converged reference's noise: a lower bound
    spp_needed = SPP_B * var_b / err_sg
    t_ref = spp_needed * slope
    ratio = t_ref / sg_s
    print(f"sg: {sg_s * 1e3:.2f} ms/frame, PSNR vs converged reference "
          f"{psnr(sg_img, conv.image):.2f} dB (true-error PSNR "
          f"{10 * math.log10(PSNR_PEAK ** 2 / err_sg):.2f} dB{' — at the noise floor' if floor else ''})")
    print(f"reference: {slope * 1e3:.2f} ms per spp; MSE at {SPP_B} spp {var_b:.3e} (measured "
          f"against R*: {measured_b:.3e}); needs {spp_needed:.0f} spp = {t_ref:.2f} s "
          f"for sg's PSNR ({runs[SPP_B].samples_per_s:.3g} samples/s)")
    print(f"equal-quality speed-up sg vs reference: {ratio:.0f}× (goal ≥ {GOAL:.0f}×)"
          + (" [lower bound]" if floor else ""))
    return 0 if ratio >= GOAL else 1


if __name__ == "__main__":
    sys.exit(main())
