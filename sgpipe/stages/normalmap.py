"""The normalmap stage (part of `sgpipe precompute`): `cfg.normalmap` + the normal maps of
`cfg.scene` -> `<out>/normalmap/<map>/` (docs/HAN07.md): Han07's vMF and SH pyramids and the
single-lobe baselines per distinct normal-map file."""

from __future__ import annotations

import os
import re
import sys
import time
from pathlib import Path

import click
import numpy as np

from sgpipe.config.schema import to_plain
from sgpipe.stages.base import StageRun, log

METHOD_ROWS = ("truth", "vmf", "sh", "toksvig", "normalized")


def collect_maps(cfg) -> list[dict]:
    """Distinct normal-map files of the scene in config order: {name, path, key, objects,
    textures}; a map's name is its file stem (made unique with -2, -3 … when stems collide).
    With `normalmap.colour_features`, objects whose materials have different colour textures
    (kd_map, ks_map) get distinct pyramids of the same map: the textures are its features.
    Then the glTF materials' normal textures (`normalmap.gltf_maps.gltf_normal_maps`: with
    their decoded `texels`, samplers' `wrap` and, with colour_features, the `material` whose
    base-colour and metallic-roughness textures are their features)."""
    from sgpipe.normalmap.gltf_maps import gltf_normal_maps
    from sgpipe.normalmap.features import texture_files
    maps: dict[tuple, dict] = {}
    names: set[str] = set()
    with_features = cfg.normalmap is not None and cfg.normalmap.colour_features
    for k, o in enumerate(cfg.scene.objects if cfg.scene is not None else []):
        if o.normal_map is None:
            continue
        path = str(Path(o.normal_map).resolve())
        tex = texture_files(cfg, o.material) if with_features else (None, None)
        if (path, tex) not in maps:
            stem = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(path).stem) or "map"
            name, i = stem, 1
            while name in names:
                i += 1
                name = f"{stem}-{i}"
            names.add(name)
            maps[(path, tex)] = {"name": name, "path": o.normal_map, "key": f"scene.objects."
                                 f"{k}.normal_map", "objects": [], "textures": tex}
        maps[(path, tex)]["objects"].append(o.name)
    return list(maps.values()) + gltf_normal_maps(cfg, names, with_features)


def _bar(total: int):
    show = sys.stderr.isatty() or os.environ.get("SGPIPE_PROGRESS") == "1"
    return click.progressbar(length=total, label="normalmap: fitting", file=sys.stderr,
                             show_pos=True, show_eta=True) if show and total > 1 else None


def run(cfg, out_dir: Path, *, force: bool = False) -> StageRun | None:
    """Run the normalmap stage of a validated config (no-op when the section is absent)."""
    if cfg.normalmap is None:
        log("[normalmap] no 'normalmap:' section in the config; nothing to do")
        return None
    from sgpipe.normalmap.read import check_object_uvs, decode_normals, read_normal_texels
    maps = collect_maps(cfg)
    if not maps:
        log("[normalmap] no scene object has a normal_map or a glTF normal texture; nothing "
            "to do")
        return None
    check_object_uvs(cfg)
    texels = [m["texels"] if "texels" in m else read_normal_texels(m["path"], m["key"])
              for m in maps]                                    # validated before writing
    normals = [decode_normals(t) for t in texels]
    features = _features(maps, normals)                 # validated before writing, too
    params = {"normalmap": to_plain(cfg.normalmap),
              "maps": [{"name": m["name"], "objects": m["objects"],
                        "file": getattr(m["path"], "relative", str(m["path"])),
                        **({"wrap": m["wrap"]} if "wrap" in m else {}),
                        **({"colour_textures": [Path(p).name if p else None
                                                for p in m["textures"]]}
                           if f is not None and "material" not in m else {}),
                        **({"material_features": m["material"][0]}
                           if f is not None and "material" in m else {})}
                       for m, f in zip(maps, features)]}
    inputs = [m["path"] for m in maps] + sorted({p for m in maps for p in m["textures"] if p})
    with StageRun(cfg, Path(out_dir), "normalmap", params=params, inputs=inputs,
                  force=force) as run:
        if run.skipped:
            return run
        from sgpipe.artifacts.normalmap import FEATURE_NAMES, GLTF_FEATURE_NAMES
        from sgpipe.normalmap.vmf import VMFSettings, progress_steps
        nm = cfg.normalmap
        settings = VMFSettings(lobes=nm.lobes, levels=nm.levels, align=nm.align,
                               align_strength=nm.align_strength, max_iter=nm.em_iterations,
                               align_iter=nm.align_iterations, tol=nm.em_tolerance,
                               kappa_max=nm.kappa_max)
        steps = sum((progress_steps(n.shape[0], settings, nm.bilinear_samples)
                     if "vmf" in nm.methods else 0) + 2 for n in normals)
        bar = _bar(steps)
        try:
            for m, n, t, ft in zip(maps, normals, texels, features):
                names = GLTF_FEATURE_NAMES if "material" in m else FEATURE_NAMES
                run.report[m["name"]] = _process(run, nm, settings, m["name"], n, t, ft, names,
                                                 bar)
        finally:
            if bar:
                bar.render_finish()
        from sgpipe.artifacts.normalmap import INDEX
        run.write_json(INDEX, {"maps": params["maps"]})
    return run


def _features(maps: list[dict], normals: list) -> list:
    """Per map its (n, n, F) features (Han07 eq 22; normalmap.colour_features) or None:
    kd / ks multipliers (F = 6), or a glTF material's kd, F0, ln roughness (F = 7)."""
    from sgpipe.normalmap.features import gltf_map_features, map_features
    from sgpipe.render.setup import read_texture
    cache: dict = {}

    def read(path, key):
        if path not in cache:
            cache[path] = read_texture(path, key)
        return cache[path]
    return [gltf_map_features(*m["material"], n.shape[0]) if "material" in m
            else map_features(*m["textures"], n.shape[0], read) for m, n in zip(maps, normals)]


def _pyramids(normals: np.ndarray, texels: np.ndarray, sub: int, levels):
    """(fine, build): the sub-sample normals of the bilinear map (None for sub = 1) and
    build(per_sample, plain) → a linear pyramid whose levels ≥ 1 average per_sample over the
    sub-samples (`bilinear.continuum_pyramid`), or `plain()` (today's texel pyramid)."""
    if sub == 1:
        return None, lambda per_sample, plain: plain()
    from sgpipe.normalmap.bilinear import bilinear_normals, continuum_pyramid
    fine = bilinear_normals(texels, sub)
    return fine, lambda per_sample, plain: continuum_pyramid(normals, fine, sub, levels,
                                                             per_sample)


def _sh_map(lmax: int):
    """normals (h, w, 3) → Y_lm (h, w, (lmax+1)²) (`sh.ndf_sh_pyramid`'s level 0)."""
    from sgpipe.normalmap._sh_jit import sh_eval_map, sh_norms
    norms = sh_norms(lmax)

    def f(x):
        x = np.ascontiguousarray(x, np.float64)
        out = np.empty(x.shape[:2] + ((lmax + 1) ** 2,))
        sh_eval_map(x, int(lmax), norms, out)
        return out
    return f


def _process(run: StageRun, nm, settings, name: str, normals: np.ndarray, texels: np.ndarray,
             features: np.ndarray | None, feature_names: tuple, bar) -> dict:
    from sgpipe.artifacts import normalmap as art
    from sgpipe.normalmap import pyramid as P
    from sgpipe.normalmap import quality as Q
    from sgpipe.normalmap.sh import ndf_sh_pyramid
    from sgpipe.normalmap.vmf import fit_vmf_pyramid

    def tick(k=1, what=""):
        if bar:
            bar.update(k)

    n_lev = P.level_count(normals.shape[0], nm.levels)
    h = Q.half_vector(nm.preview_light_deg)
    s = float(nm.toksvig_exponent)
    # levels ≥ 1 from s × s sub-samples of the bilinear map (docs/HAN07.md) when asked
    fine, build = _pyramids(normals, texels, nm.bilinear_samples, nm.levels)
    shade = {"truth": build(lambda x: Q.truth_samples(x, s, h),
                            lambda: Q.truth_levels(normals, s, h, n_lev))}
    t = time.perf_counter()
    mean = build(None, lambda: P.mean_normal_pyramid(normals, nm.levels))
    if "baselines" in nm.methods:
        art.write_baselines(run, name, mean=mean,
                            toksvig=[P.toksvig_factor(m, s) for m in mean],
                            kappa=[P.engine_kappa(m, nm.kappa_max) for m in mean],
                            roughness=[P.engine_roughness(m, nm.engine_alpha, nm.kappa_max)
                                       for m in mean],
                            toksvig_exponent=s, engine_alpha=nm.engine_alpha)
    shade["toksvig"], shade["normalized"] = zip(*[Q.baseline_levels(m, s, h) for m in mean])
    run.timings[f"{name}.baselines_s"] = time.perf_counter() - t
    tick()
    if "sh" in nm.methods:
        t = time.perf_counter()
        gamma = build(_sh_map(nm.sh_order),
                      lambda: ndf_sh_pyramid(normals, nm.sh_order, nm.levels))
        run.timings[f"{name}.sh_s"] = time.perf_counter() - t
        art.write_sh(run, name, gamma, nm.sh_order)
        shade["sh"] = [Q.sh_level(g, s, h) for g in gamma]
    tick()
    if "vmf" in nm.methods:
        t = time.perf_counter()
        pyr = fit_vmf_pyramid(normals, settings, progress=tick, fine=fine, features=features)
        run.timings[f"{name}.vmf_s"] = time.perf_counter() - t
        art.write_vmf(run, name, pyr.alpha, pyr.alpha_r, kappa_max=nm.kappa_max,
                      aligned=nm.align, alpha_f=pyr.alpha_f, feature_names=feature_names)
        shade["vmf"] = [Q.vmf_level(a, ar, s, h) for a, ar in zip(pyr.alpha, pyr.alpha_r)]
    rows = [r for r in METHOD_ROWS if r in shade]
    errors = {r: [round(Q.rel_rms(np.asarray(shade[r][lev]), shade["truth"][lev]), 6)
                  for lev in range(n_lev)] for r in rows if r != "truth"}
    quality = {"blinn_phong_exponent": s, "half_vector": h.tolist(),
               "rel_rms_by_level": errors, "rows_of_preview": rows}
    run.write_json(art.map_file(name, art.QUALITY), quality)
    peak = float(shade["truth"][0].max()) or 1.0
    strips = [art.atlas([np.asarray(x, np.float32)[..., None] / peak for x in shade[r]])
              for r in rows]
    gap = np.zeros((2,) + strips[0].shape[1:], np.float32)
    run.write_png(art.map_file(name, art.PREVIEW_LEVELS),
                  np.concatenate(sum([[st, gap] for st in strips], [])[:-1])[..., 0])
    log(f"[normalmap] {name}: {normals.shape[0]}² map, {n_lev} levels; Blinn–Phong s = {s:g} "
        f"rel. error at the coarsest level: "
        + ", ".join(f"{r} {errors[r][-1]:.3f}" for r in errors))
    return {"side": int(normals.shape[0]), "levels": n_lev, "rel_rms_by_level": errors}
