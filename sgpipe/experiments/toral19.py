"""Töral19's ablation ladder on the fidelity corpus: `gmm_toral19` (the paper as published),
then each sgpipe improvement given back one at a time (render.gmm_toral19_adds, in
sgpipe.render.methods.TORAL19_SWITCHES order) up to `gmm` (sgpipe.experiments.ladder).

    python -m sgpipe.experiments.toral19 --seed 11 13 --results docs/results/toral19.md
"""

from __future__ import annotations

import sys

from sgpipe.experiments.ladder import Ladder, main
from sgpipe.render.methods import TORAL19_SWITCHES

LADDER = Ladder(paper="Töral19", method="gmm_toral19", adds_key="render.gmm_toral19_adds",
                switches=tuple(TORAL19_SWITCHES), default="gmm", doc="docs/TORAL19.md",
                module="toral19")

if __name__ == "__main__":
    sys.exit(main(LADDER))
