"""The fit stage: `cfg.fit` -> artifacts under `<out>/fit/`."""

from __future__ import annotations

from pathlib import Path

from sgpipe.stages.base import log


def run(cfg, out_dir: Path, *, force: bool = False) -> None:
    """Run the fit stage of a validated config (no-op when the section is absent)."""
    if cfg.fit is None:
        log("[fit] no 'fit:' section in the config; nothing to do")
        return
    log("[fit] not implemented yet")
