"""The envmap stage: `cfg.envmap` -> artifacts under `<out>/envmap/`."""

from __future__ import annotations

from pathlib import Path

from sgpipe.stages.base import log


def run(cfg, out_dir: Path, *, force: bool = False) -> None:
    """Run the envmap stage of a validated config (no-op when the section is absent)."""
    if cfg.envmap is None:
        log("[envmap] no 'envmap:' section in the config; nothing to do")
        return
    log("[envmap] not implemented yet")
