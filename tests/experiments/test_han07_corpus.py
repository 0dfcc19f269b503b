"""The Han07 results page's corpus section (sgpipe.experiments.han07_corpus) on synthetic rows:
the minification from the slot key, the 16×/64× target (≥ 30 dB and ≥ 6 dB over the best
unfiltered method), the 1× target (every Han07 method within 1 dB of the reference's seed
agreement), and a missing corpus file as one line."""

from __future__ import annotations

import json

from sgpipe.experiments.han07_corpus import corpus_section, minification, verdict


def _row(key, cells, agree=40.0):
    return {"key": key, "seed": 11, "normal_map": "grooves", "seed_surface_psnr_db": agree,
            "methods": {m: {"surface_display_psnr_db": v} for m, v in cells.items()},
            "errors": {}}


def test_minification_from_the_slot_key():
    assert minification("plane-sky-nm_beckmann-vgrooves64x-directional") == 64
    assert minification("grazing-sky-nm_beckmann-grooves4x") == 4
    assert minification("sphere-lamps-ggx_diffuse") is None


def test_sixteen_and_sixty_four_times_need_thirty_db_and_six_over_unfiltered():
    ok, why = verdict(_row("p-nm_x-vgrooves16x", {"vmf": 36.0, "toksvig": 20.0, "sg": 29.9}))
    assert ok and "+6.1 dB over sg" in why
    assert not verdict(_row("p-nm_x-vgrooves16x", {"vmf": 36.0, "gmm": 30.1}))[0]
    assert not verdict(_row("p-nm_x-bumps64x", {"vmf": 29.9, "fis": 10.0}))[0]
    assert verdict(_row("p-nm_x-bumps4x", {"vmf": 10.0, "sg": 40.0}))[0] is None


def test_one_times_needs_every_han07_method_near_the_reference_agreement():
    assert verdict(_row("p-nm_x-grooves1x", {"vmf": 39.5, "nm_sh": 39.1, "sg": 45.0}))[0]
    ok, why = verdict(_row("p-nm_x-grooves1x", {"vmf": 39.5, "nm_sh": 38.9, "sg": 20.0}))
    assert not ok and "worst nm_sh 38.9 dB" in why


def test_section_from_a_corpus_file_and_without_one(tmp_path):
    meta = {"seeds": [11], "tuning_seeds": [1, 7], "size": 96, "spp": 1024}
    rows = [_row("p-nm_x-vgrooves16x", {"vmf": 36.0, "sg": 20.0}),
            {"key": "sphere-lamps-ggx", "normal_map": None}]
    path = tmp_path / "fidelity.json"
    path.write_text(json.dumps({"meta": meta, "rows": rows}))
    text = "\n".join(corpus_section(path))
    assert "| s11 `p-nm_x-vgrooves16x` | 36.0 |" in text and "sphere-lamps" not in text
    assert "not a tuning seed" in text and "| met |" in text
    missing = corpus_section(tmp_path / "none.json")
    assert any(line.startswith("Not available:") for line in missing)
