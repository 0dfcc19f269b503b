"""Argument checks shared by the CLI's commands (sgpipe.cli, sgpipe.export.command,
sgpipe.report.command): each turns a bad argument into one BadInput line naming the option."""

from __future__ import annotations

from pathlib import Path

from sgpipe.errors import BadInput


def out_folder(ctx, param, value: str | None) -> Path | None:
    """--out as a Path; an empty value (a shell variable that was not set) is refused instead
    of meaning the current folder, and so is an existing file."""
    if value is None:
        return None
    if not value.strip():
        raise BadInput("is empty; give a folder (`--out .` for the current one)", key="--out")
    p = Path(value)
    if p.exists() and not p.is_dir():
        raise BadInput("is a file, not a folder", file=p, key="--out")
    return p
