"""The fidelity corpus's page and goal line (sgpipe.experiments.corpus.report,
sgpipe.experiments.fidelity) on synthetic rows: the worst cell per method is the minimum, a
refusal reads n/a and a crash reads failed, normal-mapped scenes stay out of the goal."""

from __future__ import annotations

from sgpipe.experiments.corpus.report import markdown
from sgpipe.experiments.fidelity import goal_misses


def _v(db: float) -> dict:
    return {"surface_display_psnr_db": db, "display_psnr_db": db + 1.0,
            "raw_surface_display_psnr_db": db, "surface_floor_db": db + 10.0, "floor_db": 60.0,
            "surface_flip_ldr": 0.01, "flip_ldr": 0.01, "surface_rel_mse": 1e-3,
            "rel_mse": 1e-3, "ms": 12.0}


def _row(key, methods, errors=None, normal_map=None) -> dict:
    return {"key": key, "seed": 7, "normal_map": normal_map, "clipped": 0.0, "exposure": 0.0,
            "seed_surface_psnr_db": 40.0,
            "material": {"model": "ggx", "params": {"alpha": 0.1}},
            "methods": {m: _v(db) for m, db in methods.items()}, "errors": errors or {}}


ROWS = [_row("a", {"sg": 40.0, "gmm": 33.0}),
        _row("b", {"sg": 31.0, "gmm": 36.0}, {"transport": "RuntimeError: boom"}),
        _row("c", {"sg": 20.0, "vmf": 30.0}, {"gmm": "BadInput: ggx has no closed form"},
             normal_map="grooves")]
META = {"seeds": [7], "tuning_seeds": [1], "size": 48, "spp": 64, "seconds": 60.0,
        "goal_db": 35.0}


def test_goal_skips_normal_mapped_scenes_and_names_each_miss():
    misses = goal_misses(ROWS)
    assert misses == ["gmm on s7 a (33.0 dB)", "sg on s7 b (31.0 dB)"]


def test_worst_cells_refusals_and_failures():
    md = markdown(ROWS, META, goal_misses(ROWS))
    worst = md.split("## Worst cell per method")[1].split("**Goal**")[0]
    assert "| sg | s7 `c` | 20.0 |" in worst           # the minimum over every scene
    assert "| gmm | s7 `a` | 33.0 |" in worst
    matrix = md.split("## Surface display PSNR")[1].split("## Whole frame")[0]
    row_b = next(line for line in matrix.splitlines() if "`b`" in line)
    row_c = next(line for line in matrix.splitlines() if "`c`" in line)
    assert "**failed**" in row_b and "n/a" in row_c
    assert "**not met** on 2 cells" in md
    assert "not a seed any method was tuned on" in md
    tuned = markdown(ROWS, dict(META, seeds=[1]), [])
    assert "**a tuning seed**" in tuned and "**met**" in tuned


def test_regenerate_line_names_the_report_file():
    """The report seed's file is part of `make figures`; another seed's names its own file."""
    main = markdown(ROWS, META, [])
    assert "--results docs/results/fidelity.md` (part of `make figures`;" in main
    other = markdown(ROWS, dict(META, results="docs/results/fidelity_seed7.md"), [])
    assert "--results docs/results/fidelity_seed7.md` (" in other
    assert "make figures" not in other.split("Regenerate:")[1].split("\n")[0]


def test_update_replaces_the_re_measured_rows_in_place():
    """`--update`: the old rows keep their order; a re-measured (seed, key) replaces its row;
    slots new to the corpus are added."""
    from sgpipe.experiments.fidelity import merge_rows
    new_c = _row("c", {"sg": 21.0, "vmf": 35.0}, normal_map="grooves")
    merged = merge_rows(ROWS, [new_c])
    assert [r["key"] for r in merged] == ["a", "b", "c"]
    assert merged[2] is new_c and merged[:2] == ROWS[:2]
    # a (seed, key) the old run did not have replaces nothing and comes after the old rows
    other_seed = dict(new_c, seed=11)
    new_slot = _row("d", {"sg": 30.0})
    merged = merge_rows(ROWS, [new_slot, other_seed])
    assert merged[:3] == ROWS and merged[3:] == [new_slot, other_seed]


def test_update_refuses_without_scenes_or_with_another_run(tmp_path, capsys):
    """One line and exit status 2, before anything is measured: no --scenes, no previous
    fidelity.json, or one of other seeds / size / spp."""
    import json

    from sgpipe.experiments.fidelity import main
    assert main(["--out", str(tmp_path), "--update", "--seed", "7"]) == 2
    assert "--update needs --scenes" in capsys.readouterr().err
    key = "plane-lamps-ggx"
    assert main(["--out", str(tmp_path), "--update", "--seed", "7", "--scenes", key]) == 2
    assert "fidelity.json" in capsys.readouterr().err
    (tmp_path / "fidelity.json").write_text(json.dumps({"meta": META, "rows": ROWS}))
    assert main(["--out", str(tmp_path), "--update", "--seed", "11", "--scenes", key]) == 2
    err = capsys.readouterr().err
    assert "meta seeds is [7], this run's is [11]" in err and len(err.splitlines()) == 1
