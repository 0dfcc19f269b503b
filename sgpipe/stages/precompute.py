"""`sgpipe precompute`: the environment, visibility, normal-map (Han07) and transport (Green06)
stages, each a no-op when its config section is absent."""

from __future__ import annotations

from pathlib import Path

from sgpipe.stages import envmap, normalmap, transport, visibility


def run(cfg, out_dir: Path, *, force: bool = False) -> None:
    """Run every precompute sub-stage present in the config."""
    envmap.run(cfg, out_dir, force=force)
    visibility.run(cfg, out_dir, force=force)
    normalmap.run(cfg, out_dir, force=force)
    transport.run(cfg, out_dir, force=force)
