"""`sgpipe precompute`: the environment stage, then the visibility stage."""

from __future__ import annotations

from pathlib import Path

from sgpipe.stages import envmap, visibility


def run(cfg, out_dir: Path, *, force: bool = False) -> None:
    """Run every precompute sub-stage present in the config."""
    envmap.run(cfg, out_dir, force=force)
    visibility.run(cfg, out_dir, force=force)
