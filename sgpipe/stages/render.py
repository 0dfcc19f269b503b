"""The render stage: `cfg.render` -> artifacts under `<out>/render/`."""

from __future__ import annotations

from pathlib import Path

from sgpipe.stages.base import log


def run(cfg, out_dir: Path, *, force: bool = False) -> None:
    """Run the render stage of a validated config (no-op when the section is absent)."""
    if cfg.render is None:
        log("[render] no 'render:' section in the config; nothing to do")
        return
    log("[render] not implemented yet")
