"""Han07's ablation ladder on the fidelity corpus's normal-mapped scenes: `vmf_han07` (§7–8 as
published: the trilinear eq 24 lookup, eq 20–21 for lights, §8's SH environment at l* = 8), then
each sgpipe improvement given back one at a time (render.vmf_han07_adds, in
sgpipe.render.methods.HAN07_SWITCHES order) up to `vmf` (sgpipe.experiments.ladder). Both read
the normal-map stage's pyramids as the corpus configures them.

    python -m sgpipe.experiments.han07_ladder --seed 11 13 --results docs/results/han07_ladder.md
"""

from __future__ import annotations

import sys

from sgpipe.experiments.ladder import Ladder, main
from sgpipe.render.methods import HAN07_SWITCHES

LADDER = Ladder(paper="Han07", method="vmf_han07", adds_key="render.vmf_han07_adds",
                switches=tuple(HAN07_SWITCHES), default="vmf", doc="docs/HAN07.md",
                module="han07_ladder", normal_mapped=True,
                scenes_note="the fidelity corpus's normal-mapped slots (docs/results/"
                            "fidelity.md: planes head-on and grazing, a UV sphere; grooves, "
                            "v-grooves and bumps minified 1–64×)")

if __name__ == "__main__":
    sys.exit(main(LADDER))
