"""`sgpipe export`: the click command (arguments only; the work lives in sgpipe.export)."""

from __future__ import annotations

import click


@click.command()
@click.argument("run_dir", type=click.Path(file_okay=False))
def export(run_dir):
    """Export RUN_DIR's artifacts for real-time engines."""
    raise click.UsageError("sgpipe export: under construction")
