"""`sgpipe report`: the click command (arguments only; the work lives in sgpipe.report.build)."""

from __future__ import annotations

from pathlib import Path

import click

from sgpipe.cli_args import out_folder


@click.command()
@click.argument("run_dir", type=click.Path(path_type=Path))
@click.option("--out", "out_dir", type=str, callback=out_folder, default=None,
              help="Report folder (default: RUN_DIR/report); index.html and assets/ go there.")
def report(run_dir, out_dir):
    """Write a self-contained static HTML report of RUN_DIR (the --out folder of `sgpipe run`):
    each method's image against the reference with a slider and a difference view, the
    metrics and timings, the fit plots, the environment previews, the visibility PCA and every
    stage's manifest. Works on partial runs; absent stages are said so on the page."""
    from sgpipe.report.build import write_report
    index = write_report(run_dir, out_dir)
    click.echo(f"report: {index}")
