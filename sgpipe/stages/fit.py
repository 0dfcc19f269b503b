"""The fit stage: `cfg.fit` -> artifacts under `<out>/fit/<material>/` (contract:
sgpipe.artifacts.fit, docs/ARTIFACTS.md)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sgpipe.artifacts import fit as artifacts
from sgpipe.brdf import LUMINANCE, REGISTRY, BRDFParamError, brdf_from_spec
from sgpipe.config.schema import to_plain
from sgpipe.errors import BadInput
from sgpipe.fit.ndf_asg import ndf_asg
from sgpipe.fit.ndf_sg import NdfSG, analytic_ndf_sg, fit_ndf_sg, ndf_error_curve
from sgpipe.fit.plot import error_curves_figure, save_png, slice_panels_figure
from sgpipe.fit.view_gmm import (fit_view_gmm, interpolation_errors, lobe_curve,
                                 slice_images)
from sgpipe.stages.base import StageRun, log

_ENERGY_VIEWS_DEG = (0.0, 45.0, 75.0)


#: the largest directional albedo (luminance) a fitted material may have
ENERGY_LIMIT = 1.01


def energy_check_albedo(brdf) -> np.ndarray:
    """Luminance albedo at the views the fit stage checks (_ENERGY_VIEWS_DEG)."""
    th = np.radians(_ENERGY_VIEWS_DEG)
    o = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    return brdf.albedo(o, n=48) @ LUMINANCE


def _build_brdf(cfg, n: int, spec):
    """Validate one material and build its BRDF; every problem is a BadInput naming the key."""
    base = f"fit.materials.{n}"
    if spec.model not in REGISTRY:
        raise BadInput(f"unknown BRDF model {spec.model!r} (known: {', '.join(sorted(REGISTRY))})",
                       file=cfg.source, key=f"{base}.model")
    try:
        brdf = brdf_from_spec(spec)
    except BRDFParamError as e:
        key = f"{base}.merl_file" if e.param == "merl_file" else f"{base}.params.{e.param}"
        raise BadInput(e.message, file=cfg.source, key=key) from None
    except BadInput as e:            # MERL file problems name the data file itself
        raise BadInput(e.message, file=e.file, key=f"{base}.merl_file") from None
    if spec.model != "merl":
        alb = energy_check_albedo(brdf)
        if np.max(alb) > ENERGY_LIMIT:
            k = int(np.argmax(alb))
            raise BadInput(f"parameters are not energy conserving: albedo {alb[k]:.3f} > 1 at "
                           f"view θ = {_ENERGY_VIEWS_DEG[k]:g}° (lower kd/ks)",
                           file=cfg.source, key=f"{base}.params")
    return brdf


def _set_threads(workers: int) -> None:
    import numba
    from sgpipe.parallel import default_workers
    n = workers or default_workers()
    numba.set_num_threads(max(1, min(n, numba.config.NUMBA_NUM_THREADS)))


def run(cfg, out_dir: Path, *, force: bool = False):
    """Run the fit stage of a validated config (no-op when the section is absent)."""
    if cfg.fit is None:
        log("[fit] no 'fit:' section in the config; nothing to do")
        return None
    fit = cfg.fit
    brdfs = [_build_brdf(cfg, n, m) for n, m in enumerate(fit.materials)]
    inputs = [str(m.merl_file) for m in fit.materials if m.merl_file is not None]
    _set_threads(cfg.workers)
    params = to_plain(fit)
    if toral19_requested(cfg):       # the published mixtures are written only when rendered
        params["gmm_toral19"] = True
    with StageRun(cfg, out_dir, "fit", params=params, inputs=inputs, force=force) as run:
        if run.skipped:
            return run
        artifacts.write_materials_index(run, [m.name for m in fit.materials])
        for n, (spec, brdf) in enumerate(zip(fit.materials, brdfs)):
            log(f"[fit] material {spec.name} ({spec.model})")
            run.report[spec.name] = fit_material(run, cfg, n, spec, brdf)
    return run


#: Töral19 §V: "for each o_j the EM algorithm is used for fitting 8 SGs"
TORAL19_LOBES = 8


def toral19_requested(cfg) -> bool:
    """Does the config render `gmm_toral19` (which reads view_gmm_toral19.npz)?"""
    return cfg.render is not None and "gmm_toral19" in cfg.render.methods


def fit_material(run: StageRun, cfg, index: int, spec, brdf) -> dict:
    """Write one material's folder; returns its summary for the manifest."""
    name = spec.name
    seed = int(cfg.seed) * 1000 + index
    report: dict = {"model": spec.model, "params": to_plain(spec.params)}
    artifacts.write_microfacet(run, name, brdf.microfacet_params())
    if hasattr(brdf, "fit"):
        report["tabulated"] = write_tabulated(run, name, brdf.fit)
    t0 = time.perf_counter()
    report["ndf_sg"] = write_ndf_sg(run, name, brdf, cfg.fit.ndf_sg, seed)
    run.timings[f"{name}.ndf_sg_s"] = time.perf_counter() - t0
    if cfg.fit.view_gmm.enabled:
        t0 = time.perf_counter()
        report["view_gmm"] = write_view_gmm(run, name, brdf, cfg.fit.view_gmm, seed,
                                            report["ndf_sg"])
        run.timings[f"{name}.view_gmm_s"] = time.perf_counter() - t0
    run.write_json(artifacts.material_file(name, artifacts.REPORT), report)
    summary = {"ndf_sg_rel_l2": report["ndf_sg"].get("rel_l2")}
    if "view_gmm" in report:
        summary["view_gmm_max_rel_l2"] = report["view_gmm"]["max_rel_l2"]
    return summary


def write_tabulated(run, name: str, tab) -> dict:
    artifacts.write_tabulated(run, name, tab.arrays())
    return {"rel_err": tab.rel_err, "kd": tab.kd, "ks": tab.ks, "eta": tab.eta,
            "shadow_pca_error": float(np.max(np.abs(tab.shadow - tab.shadow_raw)))}


def write_ndf_sg(run, name: str, brdf, spec, seed: int) -> dict:
    """ndf_sg.npz (possibly 0 lobes) and the NDF part of the report."""
    ndf = brdf.ndf_model
    if not (spec.enabled and brdf.has_specular):
        empty = NdfSG(np.zeros((0, 3)), np.zeros(0), np.zeros(0), "none", 0.0)
        artifacts.write_ndf_sg(run, name, empty.arrays())
        return {"lobes": 0, "method": "none"}
    sg = fit_ndf_sg(ndf, method=spec.method, n_lobes=spec.lobes, seed=seed)  # 0: auto_ndf_sg
    lobes = int(sg.axis.shape[0])
    artifacts.write_ndf_sg(run, name, sg.arrays())
    rep = {"lobes": lobes, "method": sg.method, "rel_l2": sg.rel_l2, "area_err": sg.area_err,
           "tail_err": sg.tail_err,
           "sharpness": sg.sharpness, "amplitude": sg.amplitude, "axis": sg.axis}
    an = analytic_ndf_sg(ndf)
    if an is not None:
        an = fit_ndf_sg(ndf, method="analytic")
        rep["analytic"] = {"sharpness": float(an.sharpness[0]),
                           "amplitude": float(an.amplitude[0]), "rel_l2": an.rel_l2}
    if getattr(brdf, "name", None) in ("gltf_pbr", "ggx") and ndf.isotropic:
        rep["roughness_grid"] = write_ndf_sg_rough(run, name)
    if spec.anisotropic == "asg" and not ndf.isotropic:
        asg, rep["asg"] = ndf_asg(ndf, spec.asg_lobes)
        artifacts.write_ndf_asg(run, name, asg.arrays())
    if spec.report_lobes:
        fits = ndf_error_curve(ndf, spec.report_lobes, seed=seed)
        rep["curve"] = {"lobes": list(range(1, len(fits) + 1)),
                        "rel_l2": [f.rel_l2 for f in fits]}
    return rep


def write_ndf_sg_rough(run, name: str) -> dict:
    """ndf_sg_rough.npz of an isotropic GGX material (gltf_pbr, whose roughness may come from
    a texture: Wang09 §4.1's per-pixel lobes; ggx): the lobes per roughness, which `sg` also
    renders a uniform one with (render.energy), and its part of the report."""
    from sgpipe.brdf.ndf import GGXNDF
    from sgpipe.fit.ndf_sg_rough import fit_roughness_grid
    grid = fit_roughness_grid(GGXNDF)
    artifacts.write_ndf_sg_rough(run, name, grid.arrays())
    return {"entries": len(grid.alpha), "lobes": int(grid.sharpness.shape[1]),
            "alpha": [float(grid.alpha[0]), float(grid.alpha[-1])],
            "max_rel_l2": float(grid.rel_l2.max()),
            "max_interpolated_rel_l2": float(grid.mid_rel_l2.max()),
            "max_direct_mid_rel_l2": float(grid.mid_direct_rel_l2.max())}


def write_view_gmm_toral19(run, name: str, brdf, spec, kw: dict, gmm) -> float:
    """view_gmm_toral19.npz: Töral19 §IV–V's mixtures — 8 lobes for every BRDF, each view fitted
    independently, the specular part (the diffuse one when there is none) — refitted only
    where `fit.view_gmm` differs from that, else `gmm` itself."""
    lobes = kw["n_lobes"]
    if not getattr(brdf, "isotropic", True):
        lobes = kw["anisotropic_lobes"] or lobes
    include_diffuse = not brdf.has_specular
    if lobes != TORAL19_LOBES or spec.coherent or kw["include_diffuse"] != include_diffuse:
        gmm = fit_view_gmm(brdf, coherent=False,
                           **{**kw, "n_lobes": TORAL19_LOBES, "anisotropic_lobes": 0,
                              "include_diffuse": include_diffuse})
    artifacts.write_view_gmm_toral19(run, name, gmm.arrays())
    return float(gmm.rel_l2.max())


def write_view_gmm_rough(run, name: str, brdf, spec, kw: dict) -> dict:
    """view_gmm_rough.npz of an isotropic gltf_pbr material (its roughness, metalness and
    colour may come from textures: gmm's per-pixel mixtures) and its part of the report."""
    from sgpipe.fit.view_gmm_rough import fit_rough_view_gmm
    t0 = time.perf_counter()
    grid = fit_rough_view_gmm(float(brdf.params.get("roughness", 1.0)), spec.roughness_entries,
                              **{**kw, "coherent": spec.coherent})
    arrays = grid.arrays()
    artifacts.write_view_gmm_rough(run, name, arrays)
    run.timings[f"{name}.view_gmm_rough_s"] = time.perf_counter() - t0
    return {"entries": len(grid.roughness), "roughness": grid.roughness,
            "max_rel_l2": float(np.max(arrays["rel_l2"])),
            "bytes": int(sum(np.asarray(arrays[k], np.float32).nbytes
                             for k in ("alpha", "kappa", "mu_theta", "mu_phi")))}


def write_view_gmm(run, name: str, brdf, spec, seed: int, ndf_rep: dict) -> dict:
    """view_gmm.npz + view_gmm.exr, error curve and slice previews, interpolation errors."""
    include_diffuse = spec.component == "full" or not brdf.has_specular
    n_phi = spec.phi_count or (1 if brdf.isotropic else 16)
    kw = dict(n_theta=spec.theta_count, n_phi=n_phi, theta_max=np.radians(spec.theta_max_deg),
              n_lobes=spec.lobes, n_samples=spec.samples, max_iter=spec.iterations,
              tol=spec.tolerance, align=spec.align, seed=seed, include_diffuse=include_diffuse,
              anisotropic_lobes=spec.anisotropic_lobes)
    gmm = fit_view_gmm(brdf, coherent=spec.coherent, **kw)
    artifacts.write_view_gmm(run, name, gmm.arrays(),
                             view_theta_max=np.radians(spec.theta_max_deg))
    th_deg = np.degrees(gmm.view_theta)
    per_view = gmm.rel_l2.reshape(len(gmm.view_theta), n_phi).max(axis=1)
    rep = {"lobes": spec.lobes, "samples": spec.samples, "views": int(gmm.view_dirs.shape[0]),
           "includes_diffuse": include_diffuse, "coherent": spec.coherent,
           "view_theta_deg": th_deg, "rel_l2_per_theta": per_view,
           "max_rel_l2": float(gmm.rel_l2.max()),
           "max_rel_l2_theta_le_60": float(per_view[th_deg <= 60.0 + 1e-9].max(initial=0.0))}
    if spec.roughness_entries and getattr(brdf, "name", None) == "gltf_pbr" and brdf.isotropic:
        rep["roughness_grid"] = write_view_gmm_rough(run, name, brdf, spec, kw)
    if toral19_requested(run.cfg):
        rep["toral19_max_rel_l2"] = write_view_gmm_toral19(run, name, brdf, spec, kw, gmm)
    thetas = np.radians(spec.report_views_deg)
    series = []
    if spec.report_lobes:
        curve = lobe_curve(brdf, thetas, spec.report_lobes, n_samples=spec.samples, seed=seed,
                           include_diffuse=include_diffuse, max_iter=spec.iterations,
                           tol=spec.tolerance)
        rep["curve"] = {"lobes": list(range(1, spec.report_lobes + 1)),
                        "view_theta_deg": list(spec.report_views_deg), "rel_l2": curve,
                        "rel_l2_mean": curve.mean(axis=0)}
        series += [(f"vMF mixture, view θ = {t:g}°", rep["curve"]["lobes"], list(c))
                   for t, c in zip(spec.report_views_deg, curve)]
    if "curve" in ndf_rep:
        series.append(("NDF SG fit (Wang09)", ndf_rep["curve"]["lobes"], ndf_rep["curve"]["rel_l2"]))
    if series:
        save_png(error_curves_figure(series, title=f"{name}: fit error vs lobes"),
                 run.path(artifacts.material_file(name, artifacts.ERROR_PLOT)))
    if len(thetas):
        grid = [np.degrees(gmm.view_theta[np.argmin(np.abs(gmm.view_theta - t))]) for t in thetas]
        save_png(slice_panels_figure(slice_images(brdf, gmm, thetas),
                                     [f"{name}, view θ = {t:.1f}°" for t in grid]),
                 run.path(artifacts.material_file(name, artifacts.SLICES)))
    if spec.holdout and spec.theta_count > 1:
        th_h, err = interpolation_errors(brdf, gmm)
        key = "coherent" if spec.coherent else "independent"
        rep["interpolation"] = {"heldout_theta_deg": np.degrees(th_h), key: err}
        if spec.coherent:
            other = fit_view_gmm(brdf, coherent=False, errors=False, **kw)
            rep["interpolation"]["independent"] = interpolation_errors(brdf, other)[1]
        for k in ("coherent", "independent"):
            if k in rep["interpolation"]:
                rep["interpolation"][f"{k}_mean"] = float(np.mean(rep["interpolation"][k]))
    rep["albedo_lum"] = gmm.albedo @ LUMINANCE
    return rep

