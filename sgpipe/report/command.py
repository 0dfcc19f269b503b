"""`sgpipe report`: the click command (arguments only; the work lives in sgpipe.report)."""

from __future__ import annotations

import click


@click.command()
@click.argument("run_dir", type=click.Path(file_okay=False))
def report(run_dir):
    """Write a static HTML report of RUN_DIR."""
    raise click.UsageError("sgpipe report: under construction")
