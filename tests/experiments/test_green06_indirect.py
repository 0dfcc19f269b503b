"""The one-bounce page (sgpipe.experiments.green06_indirect): its scenes are the corpus's
bowls, pairs and balls on a floor, and its lines are judged from the cells."""

from __future__ import annotations

from sgpipe.experiments import green06_indirect as g


def test_scenes_are_the_bouncing_corpus_slots():
    assert len(g.SLOTS_BOUNCING) == 7
    assert all(k.split("-")[0] in ("bowl", "pair", "ball_floor") for k in g.SLOTS_BOUNCING)


def test_lines_need_the_target_and_the_margin():
    row = lambda seed, ind, tp, sg: {"seed": seed, "key": "bowl-x", "errors": {},  # noqa: E731
                                      "transport + indirect": ind, "transport": tp, "sg": sg}
    md = g.markdown([row(11, 36.5, 30.0, 29.0),      # ≥ 30 and + 6.5 over the better: met
                     row(11, 36.5, 31.0, 29.0),      # + 5.5 only: not met
                     row(13, 29.0, 20.0, 20.0),      # under 30: not met
                     row(13, None, 20.0, 20.0)],     # a method failed: no verdict
                    {"seeds": [11, 13], "spp": 64, "seconds": 60.0})
    lines = [ln for ln in md.splitlines() if ln.startswith("| 1")]
    assert [ln.rsplit("|", 2)[1].strip() for ln in lines] == ["met", "not met", "not met", "—"]
    assert "n/a" in lines[3] and "--seed 11 13" in md
