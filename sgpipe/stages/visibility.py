"""The visibility stage: `cfg.visibility` -> artifacts under `<out>/visibility/`."""

from __future__ import annotations

from pathlib import Path

from sgpipe.stages.base import log


def run(cfg, out_dir: Path, *, force: bool = False) -> None:
    """Run the visibility stage of a validated config (no-op when the section is absent)."""
    if cfg.visibility is None:
        log("[visibility] no 'visibility:' section in the config; nothing to do")
        return
    log("[visibility] not implemented yet")
