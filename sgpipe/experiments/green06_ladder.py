"""Green06's ablation ladder on the fidelity corpus's transport scenes: `transport_green06`
(§5 as published: the blended Gaussians against the whole environment and every light), then
each sgpipe improvement given back one at a time (render.transport_green06_adds, in
sgpipe.render.methods.GREEN06_SWITCHES order) up to `transport` (sgpipe.experiments.ladder).
Both read the transport stage's Gaussians as the corpus configures it (lobe sampling).

    python -m sgpipe.experiments.green06_ladder --seed 11 13 --results docs/results/green06_ladder.md
"""

from __future__ import annotations

import sys

from sgpipe.experiments.corpus.scenes import SLOTS, TRANSPORT_SHAPES
from sgpipe.experiments.ladder import Ladder, main
from sgpipe.render.methods import GREEN06_SWITCHES

LADDER = Ladder(paper="Green06", method="transport_green06",
                adds_key="render.transport_green06_adds", switches=tuple(GREEN06_SWITCHES),
                default="transport", doc="docs/GREEN06.md", module="green06_ladder",
                slots=tuple(s.key for s in SLOTS
                            if s.shape in TRANSPORT_SHAPES and s.normal_map is None),
                scenes_note="the fidelity corpus's transport slots (docs/results/fidelity.md: "
                            "spheres, bowls, pairs, a ball on a floor)")

if __name__ == "__main__":
    sys.exit(main(LADDER))
