"""`sgpipe export`: the click command (arguments only; the work lives in sgpipe.export.bundle)."""

from __future__ import annotations

from pathlib import Path

import click

from sgpipe.cli_args import out_folder


@click.command()
@click.argument("run_dir", type=click.Path(path_type=Path))
@click.option("--out", "out_dir", type=str, callback=out_folder, default=None,
              help="Export folder (default: RUN_DIR/export); replaced as a whole.")
@click.option("--format", "fmt", default="rgba16f", show_default=True, metavar="FORMAT",
              help="KTX2 texel format: rgba16f (VK_FORMAT_R16G16B16A16_SFLOAT), rgba32f "
                   "(VK_FORMAT_R32G32B32A32_SFLOAT) or b10g11r11 "
                   "(VK_FORMAT_B10G11R11_UFLOAT_PACK32). The DDS is always RGBA16F.")
@click.option("--size", type=int, default=None, metavar="N",
              help="Face size of mip 0 (default: the envmap stage's cube resolution; it may "
                   "be that divided by a power of two).")
def export(run_dir, out_dir, fmt, size):
    """Export RUN_DIR (the --out folder of `sgpipe run`) for real-time engines: the
    prefiltered environment as KTX2 and DDS cubemaps with every mip indexed by GGX roughness
    (roughness = level / (levels - 1)), SH9 irradiance as JSON, a glTF with an
    EXT_lights_image_based light and the SSDF PCA coefficients (and Green06 transport) as
    vertex attributes, and the normalmap stage's vMF / roughness MIP chains as 2-D KTX2 and
    DDS textures. A render.environment_rotation in the run's resolved config turns the glTF
    light (its rotation) and the SH9 JSON; the cubemaps stay in map space. docs/EXPORT.md
    describes every file."""
    from sgpipe.export.bundle import write_export
    out = write_export(run_dir, out_dir, fmt=fmt, size=size)
    click.echo(f"export: {out}")
