"""Wang09's experiment (Fig 7, Fig 9 and Table 1's columns on the teapot scene:
sgpipe.experiments.wang09_figures; Fig 8 on a ball and floor: wang09_fig8; the isotropic warp
against sgpipe's anisotropic one: wang09_warp) and its ablation ladder on the fidelity corpus:
`sg_wang09` (the paper as published), then each sgpipe improvement given back one at a time
(render.sg_wang09_adds, in sgpipe.render.methods.WANG09_SWITCHES order) up to `sg`
(sgpipe.experiments.ladder).

    python -m sgpipe.experiments.wang09 --seed 11 13 --results docs/results/wang09.md
"""

from __future__ import annotations

import sys

from sgpipe.experiments.ladder import Ladder, main
from sgpipe.render.methods import WANG09_SWITCHES

LADDER = Ladder(paper="Wang09", method="sg_wang09", adds_key="render.sg_wang09_adds",
                switches=tuple(WANG09_SWITCHES), default="sg", doc="docs/WANG09.md",
                module="wang09")



def teapot_experiment(args, results):
    """Fig 7, Fig 9 and Table 1 (their plots beside `results`), then Fig 8 (per-vertex vs
    per-pixel shading, sgpipe.experiments.wang09_fig8) and the warp's comparison
    (sgpipe.experiments.wang09_warp) → the page's lines."""
    from sgpipe.experiments import wang09_fig8, wang09_warp
    from sgpipe.experiments.wang09_figures import measure, write_figures
    lines = write_figures(measure(args.out / "teapot"), results)
    rows = wang09_fig8.measure(args.out / "fig8")
    wang09_fig8.figure(rows, results.parent / "figures" / "wang09_fig8.png")
    warp = wang09_warp.measure(args.out / "warp")
    wang09_warp.figure(warp, results.parent / "figures" / "wang09_warp.png")
    return (lines + wang09_fig8.markdown(rows, "figures/wang09_fig8.png")
            + wang09_warp.markdown(warp, "figures/wang09_warp.png"))


if __name__ == "__main__":
    sys.exit(main(LADDER, extra=teapot_experiment))
