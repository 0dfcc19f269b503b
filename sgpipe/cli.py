"""Command-line interface: parsing and error reporting only (GUIDE: cli -> stages)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

import sgpipe
from sgpipe.errors import BadInput

EXIT_BAD_INPUT = 2


def _config_options(f):
    f = click.option("--force", is_flag=True, help="Rerun even if inputs and parameters are "
                     "unchanged.")(f)
    f = click.option("--set", "overrides", multiple=True, metavar="KEY.PATH=VALUE",
                     help="Override a config value (YAML syntax), e.g. "
                     "--set render.camera.width=64. Repeatable.")(f)
    f = click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
                     default=None, help="Output folder (default: out/<config name>).")(f)
    f = click.argument("config", type=click.Path(path_type=Path))(f)
    return f


def _load(config: Path, overrides, out_dir: Path | None):
    from sgpipe.config import load_config
    cfg = load_config(config, overrides)
    out = out_dir if out_dir is not None else Path("out") / config.stem
    return cfg, out


def _run_stages(names: list[str], config, out_dir, overrides, force):
    import importlib
    cfg, out = _load(config, overrides, out_dir)
    for name in names:
        importlib.import_module(f"sgpipe.stages.{name}").run(cfg, out, force=force)
    click.echo(f"outputs: {out.resolve()}")


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(sgpipe.__version__, prog_name="sgpipe")
def cli():
    """sgpipe: fit materials to spherical Gaussians, precompute environment and visibility,
    render with OpenCL, and measure the result against a Monte Carlo reference.

    Each stage command reads a YAML config and writes artifacts under OUT/<stage>/.
    Exit status: 0 ok, 2 bad input, 1 internal error.
    """


@cli.command()
@_config_options
def fit(config, out_dir, overrides, force):
    """Fit the materials of CONFIG's `fit:` section into SG / vMF lobes."""
    _run_stages(["fit"], config, out_dir, overrides, force)


@cli.command()
@_config_options
def precompute(config, out_dir, overrides, force):
    """Prefilter the environment (`envmap:`) and trace visibility (`visibility:`)."""
    _run_stages(["precompute"], config, out_dir, overrides, force)


@cli.command()
@_config_options
def render(config, out_dir, overrides, force):
    """Render CONFIG's `render:` section from the fitted and precomputed artifacts."""
    _run_stages(["render"], config, out_dir, overrides, force)


@cli.command("run")
@_config_options
def run_all(config, out_dir, overrides, force):
    """Run every stage of CONFIG in order: fit, precompute, render (and its comparisons)."""
    _run_stages(["fit", "precompute", "render"], config, out_dir, overrides, force)


@cli.command()
@click.argument("image", type=click.Path(path_type=Path))
@click.argument("reference", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print the metrics as JSON.")
@click.option("--diff", "diff_png", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Write a false-colour difference PNG here.")
def compare(image, reference, as_json, diff_png):
    """Compare IMAGE against REFERENCE (linear EXR): PSNR, SSIM, relative MSE."""
    from sgpipe.stages import compare as cmp
    cmp.compare_cli(image, reference, as_json=as_json, diff_png=diff_png)


@cli.command("config-doc")
@click.argument("section", required=False)
def config_doc(section):
    """Print every config key with its type, default and documentation."""
    from sgpipe.config.root import Config
    from sgpipe.config.schema import describe
    lines = describe(Config)
    if section:
        keep, on = [], False
        for ln in lines:
            if not ln.startswith(" "):
                on = ln.split(":")[0] == section
            if on:
                keep.append(ln)
        if not keep:
            raise BadInput(f"no config section named {section!r}", key="section")
        lines = keep
    click.echo("\n".join(ln for ln in lines if "(internal)" not in ln))


@cli.command()
def doctor():
    """Check the runtime: OpenCL (builds and runs a tiny kernel), Embree, OpenImageIO, numba."""
    from sgpipe.doctor import run_doctor
    sys.exit(run_doctor())


def main(argv=None):
    """Entry point: BadInput -> one line on stderr, exit 2; bugs -> traceback, exit 1."""
    try:
        cli.main(args=argv, prog_name="sgpipe", standalone_mode=False)
    except BadInput as e:
        click.echo(f"sgpipe: error: {e.one_line()}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    except click.exceptions.Abort:
        click.echo("sgpipe: aborted", err=True)
        sys.exit(1)
    except click.ClickException as e:
        e.show()
        sys.exit(e.exit_code)
    except SystemExit:
        raise
    sys.exit(0)


if __name__ == "__main__":  # pragma: no cover
    main()
