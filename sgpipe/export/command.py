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
              help="Face size of mip 0 (default: the envmap stage's cube resolution). With "
                   "--prefilter tree and the envmap stage's panorama: any power of two up to "
                   "2048; otherwise that resolution divided by a power of two.")
@click.option("--prefilter", default="tree", show_default=True, metavar="NAME",
              help="How the cubemap mips are made: tree (hierarchical GGX quadrature of the "
                   "envmap stage's panorama) or pyramid (the Γ_L pyramid through a 4-SG GGX "
                   "mixture, direct quadrature for broad lobes).")
@click.option("--only", default=None, metavar="LIST",
              help="Write only these products (comma-separated): ktx2, dds, sh9, gltf, "
                   "normalmaps. export.json is always written.")
@click.option("--orientation", default="gltf", show_default=True, metavar="NAME",
              help="Cubemap orientation: gltf (the Khronos glTF-IBL-Sampler's, glTF-Sample-Viewer's "
                   "and three.js's: the panorama's centre column at +X) or sgpipe (its own map "
                   "space: centre column at +Z). The glTF light's rotation compensates either way.")
@click.option("--environment", type=click.Path(path_type=Path), default=None, metavar="PATH",
              help="The panorama the envmap stage read (checked against its manifest's hash); "
                   "found without this when the config's relative path resolves from the "
                   "working folder or one of its sub-folders.")
def export(run_dir, out_dir, fmt, size, orientation, prefilter, only, environment):
    """Export RUN_DIR (the --out folder of `sgpipe run`) for real-time engines: the
    prefiltered environment as KTX2 and DDS cubemaps with every mip indexed by GGX roughness
    (roughness = level / (levels - 1)), SH9 irradiance as JSON, a glTF with an
    EXT_lights_image_based light and the SSDF PCA coefficients (and Green06 transport) as
    vertex attributes, and the normalmap stage's vMF / roughness MIP chains as 2-D KTX2 and
    DDS textures. A render.environment_rotation in the run's resolved config turns the glTF
    light (its rotation) and the SH9 JSON; the cubemaps stay unturned, in --orientation. docs/EXPORT.md
    describes every file."""
    from sgpipe.export.bundle import write_export
    out = write_export(run_dir, out_dir, fmt=fmt, size=size, orientation=orientation,
                       prefilter=prefilter, only=only, environment=environment)
    click.echo(f"export: {out}")
