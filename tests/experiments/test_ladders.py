"""The papers' ablation ladders (sgpipe.experiments.ladder): each ladder's rungs run from the
published variant through its switch table, in order, to all of it (which renders sgpipe's
method, tested per variant elsewhere), and each ladder takes the corpus's slots it is about —
Han07 the normal-mapped ones, the others the rest."""

from __future__ import annotations

import pytest

from sgpipe.experiments import green06_ladder, han07_ladder, toral19, wang09
from sgpipe.experiments.corpus.scenes import scenes
from sgpipe.experiments.ladder import _skip
from sgpipe.render.methods import PUBLISHED_SWITCHES

LADDERS = [wang09.LADDER, toral19.LADDER, green06_ladder.LADDER, han07_ladder.LADDER]


@pytest.mark.parametrize("ladder", LADDERS, ids=lambda x: x.paper)
def test_rungs_walk_the_switch_table(ladder):
    table = list(PUBLISHED_SWITCHES[ladder.method])
    assert list(ladder.switches) == table
    rungs = ladder.rungs()
    assert rungs[0] == ("published", [])
    assert [adds for _, adds in rungs[1:]] == [table[:k + 1] for k in range(len(table))]


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    return scenes(7, tmp_path_factory.mktemp("ladder_corpus"), env_height=32)


def test_han07_takes_the_normal_mapped_slots_and_the_others_the_rest(corpus):
    mapped = {s["key"] for s in corpus
              if any("normal_map" in o for o in s["config"]["scene"]["objects"])}
    assert len(mapped) >= 8
    han = {s["key"] for s in corpus if not _skip(s["key"], s["config"], True)}
    rest = {s["key"] for s in corpus if not _skip(s["key"], s["config"], False)}
    assert han == mapped
    assert not rest & mapped and len(rest) >= 10
