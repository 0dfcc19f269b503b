"""Whether an upstream stage's folder was made for the current config
(sgpipe.stages.upstream.upstream_difference with the render stage's UPSTREAM sections): the
normal-map pyramids depend on the maps and the objects they belong to, not on the meshes, so a
render of the same map on another mesh (Han07's minification series: one UV tiling per mesh)
reads them; another map file is refused with its key."""

from __future__ import annotations

from pathlib import Path

import yaml

from sgpipe.config.loader import load_config
from sgpipe.stages.base import resolved_config
from sgpipe.stages.render import UPSTREAM
from sgpipe.stages.upstream import upstream_difference

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "configs" / "normalmap_render.yaml"
SECTIONS = dict((s, sec) for s, _, sec in UPSTREAM)


def _made_with(tmp: Path, cfg) -> Path:
    (tmp / "normalmap").mkdir()
    (tmp / "normalmap" / "config.resolved.yaml").write_text(
        yaml.safe_dump(resolved_config(cfg), sort_keys=True))
    return tmp


def test_normalmap_pyramids_follow_the_maps_not_the_meshes(tmp_path):
    out = _made_with(tmp_path, load_config(CONFIG))
    sphere = load_config(CONFIG, [f"scene.objects.0.mesh={ROOT / 'data_samples/sphere.obj'}"])
    assert upstream_difference(sphere, out, "normalmap", SECTIONS["normalmap"]) is None
    bumps = load_config(CONFIG, [f"scene.objects.0.normal_map="
                                 f"{ROOT / 'data_samples/normal_map.png'}"])
    diff = upstream_difference(bumps, out, "normalmap", SECTIONS["normalmap"])
    assert diff and diff.startswith("scene.objects.0.normal_map: "), diff
    lobes = load_config(CONFIG, ["normalmap.lobes=2"])
    assert upstream_difference(lobes, out, "normalmap", SECTIONS["normalmap"]).startswith(
        "normalmap.lobes: 4 -> 2")
