"""A fixed small subset of the fidelity corpus (sgpipe.experiments.fidelity): four scenes of
the report seed at 64², reference 2 × 128 spp, every method that applies.

The issue 26 goal — sg and gmm ≥ 35 dB surface display PSNR on every corpus scene without a
normal map — is PRINTED as met / not met and does not fail `make bench`; main() returns non-zero
only when a method breaks (a failure that is not a refusal of the scene's material).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from sgpipe.experiments.fidelity import REPORT_SEED, goal_misses, run_corpus

SUBSET = ("sphere-lamps-ggx_diffuse", "sphere-lamps-beckmann_aniso", "bowl-lamps-beckmann",
          "plane-lamps-nm_beckmann-vgrooves4x")
SIZE, SPP = 64, 128


def main() -> int:
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="sgpipe-bench-corpus-") as tmp:
        rows = run_corpus(Path(tmp), [REPORT_SEED], size=SIZE, spp=SPP, only=list(SUBSET),
                          log=lambda s: print(s, flush=True))
    for r in rows:
        for m, v in r["methods"].items():
            print(f"    {r['key']:40s} {m:12s} surface {v['surface_display_psnr_db']:5.1f} dB "
                  f"| frame {v['display_psnr_db']:5.1f} dB | {v['ms']:6.0f} ms/frame")
    misses = goal_misses(rows)
    print("goal ≥ 35 dB surface for sg and gmm without normal maps (printed, not gated): "
          + ("met" if not misses else "not met — " + "; ".join(misses)))
    broken = [f"{r['key']} {m}: {e}" for r in rows for m, e in r["errors"].items()
              if not e.startswith("BadInput")]
    for b in broken:
        print(f"    FAILED {b}")
    print(f"bench_corpus: {time.perf_counter() - t0:.0f} s")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
