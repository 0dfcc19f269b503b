"""The envmap stage: `cfg.envmap` -> artifacts under `<out>/envmap/` (docs/ARTIFACTS.md)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sgpipe.config.schema import to_plain
from sgpipe.stages.base import StageRun, log


def _strip(images: list[np.ndarray], h: int = 48) -> np.ndarray:
    """Lat-long thumbnails side by side, separated by a 2-pixel gap."""
    gap = np.zeros((h, 2, 3))
    parts = []
    for im in images:
        parts += [im, gap]
    return np.concatenate(parts[:-1], axis=1)


def run(cfg, out_dir: Path, *, force: bool = False) -> StageRun | None:
    """Run the envmap stage of a validated config (no-op when the section is absent)."""
    if cfg.envmap is None:
        log("[envmap] no 'envmap:' section in the config; nothing to do")
        return None
    from sgpipe.core.maps import latlong_solid_angles, latlong_texel_dirs
    from sgpipe.artifacts import envmap as artifacts
    from sgpipe.envmap import lightfit, maps, mip, store
    from sgpipe.envmap.pyramid import PyramidSettings, build_pyramid

    e = cfg.envmap
    with StageRun(cfg, out_dir, "envmap", params=to_plain(e), inputs=[e.environment],
                  force=force) as run:
        if run.skipped:
            return run
        t = time.perf_counter()
        latlong = maps.read_environment(e.environment)
        cube = maps.latlong_to_cubemap(latlong, e.cube_resolution)
        run.timings["to_cubemap_s"] = time.perf_counter() - t

        t = time.perf_counter()
        settings = PyramidSettings(ratio=e.pyramid_ratio,
                                   texels_per_sigma=e.pyramid_texels_per_sigma,
                                   lambda_min=e.pyramid_lambda_min,
                                   src_texels_per_sigma=e.pyramid_source_texels_per_sigma,
                                   bright_factor=e.pyramid_bright_factor,
                                   max_points=e.pyramid_max_points,
                                   bright_clusters=e.pyramid_bright_clusters)
        pyr = build_pyramid(cube, settings)
        run.timings["pyramid_s"] = time.perf_counter() - t
        artifacts.write_pyramid(run, store.pyramid_artifacts(pyr))
        run.report["pyramid_levels"] = len(pyr.lambdas)
        run.report["pyramid_lambda0"] = float(pyr.lambdas[0])
        run.report["pyramid_bright_texels"] = pyr.info["bright_texels"]
        run.report["pyramid_points"] = pyr.info["points"]
        run.report["pyramid_chained_levels"] = pyr.info["chained_levels"]
        run.report["pyramid_row_levels"] = pyr.info["row_levels"]
        run.report["pyramid_texels_per_sigma"] = pyr.info["texels_per_sigma"]

        t = time.perf_counter()
        cube_chain = mip.build_cube_chain(cube)
        dp_res = e.dp_resolution or e.cube_resolution
        dp = maps.cubemap_to_dual_paraboloid(cube, dp_res, e.dp_scale)
        dp_chain = mip.build_dp_chain(dp, e.dp_scale)
        artifacts.write_mip(run, cube_chain.levels, dp_chain.levels, dp_b=dp_chain.b,
                            coverage=e.mip_coverage)
        run.timings["mip_s"] = time.perf_counter() - t

        t = time.perf_counter()
        h = e.irradiance_height
        normals = latlong_texel_dirs(h, 2 * h)
        weights = latlong_solid_angles(h, 2 * h)
        exact = lightfit.irradiance_map(cube, h, 2 * h)
        artifacts.write_irradiance(run, exact)
        sg = lightfit.fit_sg_light(cube, e.sg_lobes)
        e_sg = sg.irradiance_exact(normals)
        e_sg40 = sg.irradiance_sg(normals)
        err_sg = lightfit.rel_rms(e_sg, exact, weights)
        err_sg40 = lightfit.rel_rms(e_sg40, exact, weights)
        artifacts.write_light_sg(run, axes=sg.axes, sharpness=sg.sharpness,
                                 amplitude=sg.amplitude, irradiance_rel_err=err_sg,
                                 irradiance_rel_err_eq40=err_sg40)
        sh = lightfit.sh_light(cube, e.sh_lmax)
        e_sh = lightfit.sh_irradiance(sh["irradiance_coeffs"], normals)
        err_sh = lightfit.rel_rms(e_sh, exact, weights)
        artifacts.write_light_sh(run, **sh, irradiance_rel_err=err_sh)
        run.report["sg_light_irradiance_rel_err"] = err_sg
        run.report["sg_light_irradiance_rel_err_eq40"] = err_sg40
        run.report["sh_irradiance_rel_err"] = err_sh
        run.timings["light_fits_s"] = time.perf_counter() - t

        # previews: pyramid strip (sharpest left), light fits beside the original, irradiance
        thumbs = [maps.cubemap_to_latlong(_level_faces(pyr, l), 48, 96)
                  for l in range(0, len(pyr.lambdas), max(1, len(pyr.lambdas) // 8))]
        run.write_png("preview_pyramid.png", _strip(thumbs))
        dirs = latlong_texel_dirs(96, 192)
        orig = maps.cubemap_to_latlong(cube, 96, 192)
        run.write_png("preview_light_fit.png",
                      np.concatenate([orig, np.zeros((96, 2, 3)), sg.radiance(dirs)], axis=1))
        scale = 1.0 / max(float(exact.max()), 1e-12)
        run.write_png("preview_irradiance.png",
                      np.concatenate([exact, e_sg, e_sh], axis=0) * scale)
        log(f"[envmap] pyramid {len(pyr.lambdas)} levels (λ {pyr.lambdas[0]:.0f} … "
            f"{pyr.lambdas[-1]:.2f}) in {run.timings['pyramid_s']:.2f} s; SG light "
            f"irradiance error {np.round(err_sg, 4).tolist()}, SH {np.round(err_sh, 4).tolist()}")
    return run


def _level_faces(pyr, level: int) -> np.ndarray:
    """Pyramid level → (6, n, n, 3) values at texel centres (B-spline evaluated), for previews."""
    from sgpipe.core.maps import cubemap_texel_dirs
    n = int(pyr.face_res[level])
    v, _ = pyr.level_values(level, cubemap_texel_dirs(n).reshape(-1, 3))
    return v.reshape(6, n, n, 3)
