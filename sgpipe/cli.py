"""Command-line interface: parsing, error reporting and signals only (imports point cli -> stages)."""

from __future__ import annotations

import signal
import sys
from pathlib import Path

import click

import sgpipe
from sgpipe.cli_args import out_folder
from sgpipe.errors import BadInput
from sgpipe.io.disk import disk_full_error, disk_full_line

EXIT_BAD_INPUT = 2
_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_RERAISE_S = 0.25      # how soon a swallowed interruption is raised again


class Interrupted(BaseException):
    """SIGINT or SIGTERM arrived: unwinds like KeyboardInterrupt (StageRun and map_chunks clean
    up on any BaseException), and is not caught by click, which would turn it into Abort."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


_received: list[int] = []


def _on_signal(signum, frame):
    """First SIGINT / SIGTERM: raise Interrupted, and arm a SIGALRM timer that raises it again
    whenever no exception is being handled — i.e. when a library swallowed it (trimesh wraps
    its imports in `except BaseException`). While an exception is being handled (cleanup in
    `finally` / `__exit__` / `except`), repeats and timer ticks do nothing, so cleanup is never
    cut short."""
    if not _received:
        _received.append(signum)
        signal.signal(signal.SIGALRM, _on_signal)
        signal.setitimer(signal.ITIMER_REAL, _RERAISE_S, _RERAISE_S)
        raise Interrupted(signum)
    if sys.exc_info()[1] is None:
        raise Interrupted(_received[0])


def _unraisable(hook):
    """An Interrupted that landed in a callback from C (ctypes, __del__) cannot propagate and
    would be printed as 'Exception ignored ...': the re-raise timer handles it, so stay quiet."""
    def quiet(info):
        if not isinstance(info.exc_value, Interrupted):
            hook(info)
    return quiet


def _install_signal_handlers() -> dict:
    """SIGINT / SIGTERM raise Interrupted (unless inherited as ignored, e.g. under nohup);
    returns the previous handlers."""
    import threading
    if threading.current_thread() is not threading.main_thread():
        return {}
    _received.clear()
    old = {s: signal.getsignal(s) for s in (*_SIGNALS, signal.SIGALRM)}
    old["unraisablehook"] = sys.unraisablehook
    sys.unraisablehook = _unraisable(sys.unraisablehook)
    for s in _SIGNALS:
        if old[s] is not signal.SIG_IGN:
            signal.signal(s, _on_signal)
    return old


def _restore_signal_handlers(old: dict) -> None:
    if old:
        signal.setitimer(signal.ITIMER_REAL, 0)
        sys.unraisablehook = old.pop("unraisablehook")
        for s, h in old.items():
            signal.signal(s, h)


def _keep_scheduler(ctx, param, value):
    """--scheduler / $SGPIPE_SCHEDULER, with where it came from (for the error line)."""
    env = ctx.get_parameter_source(param.name) == click.core.ParameterSource.ENVIRONMENT
    ctx.meta["sgpipe.scheduler"] = (value, "SGPIPE_SCHEDULER" if env else "--scheduler")


def _config_options(f):
    f = click.option("--scheduler", metavar="tcp://HOST:PORT", envvar="SGPIPE_SCHEDULER",
                     expose_value=False, callback=_keep_scheduler,
                     help="Run the chunked work on this Dask scheduler instead of local "
                     "processes (needs the [dask] extra; default: $SGPIPE_SCHEDULER, then the "
                     "config's `scheduler:`). Same artifacts either way.")(f)
    f = click.option("--force", is_flag=True, help="Rerun even if inputs and parameters are "
                     "unchanged.")(f)
    f = click.option("--set", "overrides", multiple=True, metavar="KEY.PATH=VALUE",
                     help="Override a config value (YAML syntax), e.g. "
                     "--set render.camera.width=64. Repeatable.")(f)
    f = click.option("--out", "out_dir", type=str, callback=out_folder,
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
    from sgpipe.stages.base import folder_lock
    from sgpipe.parallel import cluster
    cfg, out = _load(config, overrides, out_dir)
    if len(names) > 1 and cfg.scene is not None and cfg.scene.objects:
        # a bad mesh is the config's error: found before the first stage writes anything,
        # not after fit and envmap are done
        from sgpipe.io.mesh import load_scene
        load_scene(cfg.scene, sphere_subdivisions=0)
    address, key = click.get_current_context().meta.get("sgpipe.scheduler", (None, None))
    where = {"key": key} if address else {"file": cfg.source, "key": "scheduler"}
    # connected before the folder lock: an unreachable scheduler writes nothing
    with cluster(address or cfg.scheduler, **where), folder_lock(out):
        for name in names:
            importlib.import_module(f"sgpipe.stages.{name}").run(cfg, out, force=force)
    click.echo(f"outputs: {out.resolve()}")


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(sgpipe.__version__, prog_name="sgpipe")
def cli():
    """sgpipe: fit materials to spherical Gaussians, precompute environment and visibility,
    render with OpenCL, and measure the result against a Monte Carlo reference.

    Each stage command reads a YAML config and writes artifacts under OUT/<stage>/.
    Exit status: 0 ok, 2 bad input or a full disk, 1 internal error, 130 / 143 interrupted by
    SIGINT / SIGTERM (nothing half-written is left; finished stages stay).
    """


@cli.command()
@_config_options
def fit(config, out_dir, overrides, force):
    """Fit the materials of CONFIG's `fit:` section into SG / vMF lobes."""
    _run_stages(["fit"], config, out_dir, overrides, force)


@cli.command()
@_config_options
def precompute(config, out_dir, overrides, force):
    """Prefilter the environment (`envmap:`), trace visibility (`visibility:`), filter normal
    maps (`normalmap:`, Han07) and fit view-dependent transport (`transport:`, Green06)."""
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


def _threshold_options(fn):
    from sgpipe.metrics.gates import THRESHOLDS
    for t in reversed(THRESHOLDS):
        fn = click.option(t.option, t.name, type=float, default=None,
                          help=f"Fail (exit 1) when a method's {t.label} is "
                               f"{'below' if t.bound == 'min' else 'above'} this.")(fn)
    return fn


@cli.command()
@click.argument("image", type=click.Path(path_type=Path))
@click.argument("reference", type=click.Path(path_type=Path), required=False)
@click.option("--json", "as_json", is_flag=True, help="Print the metrics as JSON.")
@click.option("--diff", "diff_png", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Write a false-colour difference PNG here.")
@click.option("--exposure", type=float, default=None,
              help="Display exposure (default: the render folder's preview_exposure, else 0).")
@click.option("--gbuffer", type=click.Path(path_type=Path), default=None,
              help="gbuffer.npz (or its folder) for the surface-pixel metrics (default: the "
                   "one beside IMAGE).")
@click.option("--truth", default=None,
              help="Folders: the method to compare against (default: render.compare_to).")
@click.option("--method", "methods", multiple=True, help="Folders: only these methods.")
@_threshold_options
@click.option("--max-psnr-drop", type=float, default=0.1, show_default=True,
              help="Two folders: fail when a method's display PSNR is this many dB below "
                   "the baseline's.")
@click.option("--max-flip-rise", type=float, default=0.002, show_default=True,
              help="Two folders: fail when a method's LDR-FLIP is this much above the "
                   "baseline's.")
@click.option("--junit", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write JUnit XML here (one testcase per method and check).")
def compare(image, reference, as_json, diff_png, exposure, gbuffer, truth, methods,
            max_psnr_drop, max_flip_rise, junit, **limits):
    """Compare IMAGE against REFERENCE (linear EXRs), every method of a render folder against
    its reference, or two render folders (candidate, baseline) method by method: display
    PSNR, FLIP, relMSE, linear PSNR, SSIM. Exit 1 when a threshold fails."""
    from sgpipe.stages import compare as cmp
    failed = cmp.compare_cli(image, reference, as_json=as_json, diff_png=diff_png,
                             exposure=exposure, gbuffer=gbuffer, truth=truth,
                             methods=list(methods) or None, limits=limits,
                             psnr_drop_db=max_psnr_drop, flip_rise=max_flip_rise, junit=junit)
    if failed:
        sys.exit(1)


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


def _register_commands():
    """Commands whose code lives with their concept (click-only modules: cheap to import)."""
    from sgpipe.export.command import export
    from sgpipe.report.command import report
    cli.add_command(export)
    cli.add_command(report)


_register_commands()


def main(argv=None):
    """Entry point: BadInput or a full disk -> one line on stderr, exit 2; bugs -> traceback,
    exit 1; SIGINT / SIGTERM -> one line, exit 128 + signal number (130 / 143)."""
    old_handlers = _install_signal_handlers()
    try:
        try:
            cli.main(args=argv, prog_name="sgpipe", standalone_mode=False)
        finally:
            _restore_signal_handlers(old_handlers)
    except SystemExit:
        raise
    except BaseException as e:
        if _received or isinstance(e, Interrupted):
            # whatever ends the run after a signal (a library may have turned it into another
            # error) is the interruption: cleanup has run on the way up
            _exit_interrupted(_received[0] if _received else e.signum)
        if isinstance(e, BadInput):
            click.echo(f"sgpipe: error: {e.one_line()}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        full = disk_full_error(e)
        if full is not None:
            # the stage removed its staging folder on the way up: nothing is half-written
            click.echo(f"sgpipe: error: {disk_full_line(full)}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        if isinstance(e, click.exceptions.Abort):
            click.echo("sgpipe: aborted", err=True)
            sys.exit(1)
        if isinstance(e, click.ClickException):
            e.show()
            sys.exit(e.exit_code)
        raise
    if _received:                  # swallowed by a library, and the run went on to the end
        _exit_interrupted(_received[0])
    sys.exit(0)


def _exit_interrupted(signum: int):
    click.echo(f"sgpipe: interrupted ({signal.Signals(signum).name}); finished stages are "
               "kept", err=True)
    sys.exit(128 + signum)


if __name__ == "__main__":  # pragma: no cover
    main()
