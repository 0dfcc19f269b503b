"""Figures and the Markdown section of `sgpipe.experiments.green06` (Green06 Fig 5–7, §6.1)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

FIGS = ("fig5_lobes.png", "fig6_visibility.png", "fig6_bowl.png", "fig7_gaussians.png")
#: the bowl's methods: Green06 as published (fit and render), prefiltering without visibility,
#: then sgpipe's
BOWL_METHODS = (("transport_green06", "Green06 as published"),
                ("gmm", "prefiltered, no visibility (gmm)"),
                ("transport", "transport (sgpipe)"), ("sg", "sg (SSDF visibility)"))


def _hemisphere(values, cube_res, w=256):
    """Upper-hemisphere lat-long (+Y up) of per-texel values by nearest-texel lookup."""
    from sgpipe.core.maps import dir_to_cubemap, latlong_dir
    h = w // 4
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / (2 * h)
    d = latlong_dir(u[None, :], v[:, None])
    f, s, t = dir_to_cubemap(d)
    i = np.minimum((t * cube_res).astype(int), cube_res - 1)
    j = np.minimum((s * cube_res).astype(int), cube_res - 1)
    return np.asarray(values)[(f * cube_res + i) * cube_res + j]


def fig5(path: Path, cases) -> None:
    """Per case: data | 1 Gaussian | 7 Haar | SH images, and error vs N."""
    fig, ax = plt.subplots(len(cases), 5, figsize=(16, 2.3 * len(cases)),
                           gridspec_kw={"width_ratios": [2, 2, 2, 2, 1.4]})
    ax = np.atleast_2d(ax)
    for r, c in enumerate(cases):
        res = c["cube"].res
        vmax = float(np.max(c["T"]))
        row0 = c["rows"][0]
        panels = [("data", c["T"]), (f"1 Gaussian: {row0['gaussian']:.3f}",
                                     c["approx"]["gaussian"]),
                  (f"Haar 7: {row0['haar']:.3f}", c["approx"]["haar"]),
                  (f"SH {row0['sh_coefficients']}: {row0['sh']:.3f}", c["approx"]["sh"])]
        for k, (title, vals) in enumerate(panels):
            ax[r, k].imshow(_hemisphere(vals, res), cmap="magma", vmin=0, vmax=vmax)
            ax[r, k].set_title(title, fontsize=8)
            ax[r, k].axis("off")
        ax[r, 0].set_ylabel(c["name"])
        n = [x["gaussians"] for x in c["rows"]]
        for key, lab in (("gaussian", "Gaussians"), ("haar", "Haar 7N"), ("sh", "SH ≥ 7N")):
            ax[r, 4].plot(n, [x[key] for x in c["rows"]], "o-", label=lab)
        ax[r, 4].set_xticks(n)
        ax[r, 4].set_ylim(0, 1.05)
        ax[r, 4].set_title(c["name"], fontsize=8)
        ax[r, 4].set_xlabel("N", fontsize=8)
        ax[r, 4].legend(fontsize=6)
    fig.suptitle("Green06 Fig 5: relative L2 error (upper hemisphere, lat-long, +Y up)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _show(ax, img, exposure, title):
    from sgpipe.metrics.display import display_image
    ax.imshow(display_image(img, exposure=exposure))
    ax.set_title(title, fontsize=8)
    ax.axis("off")


def _method_rows(path: Path, scenes: dict, exposure: dict, methods, caption) -> None:
    """Per environment of `scenes`: reference | each (method, label) of `methods` captioned
    `caption(scores)` (a method without scores: an empty panel)."""
    envs = [e for e, s in scenes.items() if "error" not in s]
    if not envs:
        return
    fig, ax = plt.subplots(len(envs), 1 + len(methods),
                           figsize=(3 * (1 + len(methods)), 3.1 * len(envs)))
    ax = np.atleast_2d(ax)
    for r, e in enumerate(envs):
        s = scenes[e]
        _show(ax[r, 0], s["reference"], exposure[e], f"{e}: reference")
        for k, (m, lab) in enumerate(methods, start=1):
            if f"{m}_scores" not in s:
                ax[r, k].axis("off")
                continue
            _show(ax[r, k], s[m], exposure[e], f"{lab}\n{caption(s[f'{m}_scores'])}")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def fig6(path: Path, scenes: dict, exposure: dict) -> None:
    """The floor scene per environment: reference | Green06 (visibility) | gmm (no
    visibility) | sg."""
    _method_rows(path, scenes, exposure,
                 (("transport_green06", "Green06 (visibility)"),
                  ("gmm", "prefiltered, no visibility (gmm)"), ("sg", "sg (SSDF visibility)")),
                 lambda sc: f"ball {sc['ball_psnr']:.2f} dB, surfaces {sc['surface_psnr']:.2f} dB")


def fig6_bowl(path: Path, bowls: dict, exposure: dict) -> None:
    """The glossy bowl per environment: reference | each of BOWL_METHODS."""
    _method_rows(path, bowls, exposure, BOWL_METHODS,
                 lambda sc: f"bowl {sc['ball_psnr']:.2f} dB")


def fig7(path: Path, k1: dict, k2: dict, exposure: float) -> None:
    """Reference | 1 Gaussian | 2 Gaussians (studio)."""
    if "error" in k1 or "error" in k2 or not k1:
        return
    fig, ax = plt.subplots(1, 3, figsize=(9, 3.2))
    _show(ax[0], k1["reference"], exposure, "reference")
    for k, (s, lab) in enumerate(((k1, "1 Gaussian"), (k2, "2 Gaussians")), start=1):
        sc = s["transport_green06_scores"]
        _show(ax[k], s["transport_green06"], exposure,
              f"{lab}: ball {sc['ball_psnr']:.2f} dB, FLIP {sc['ball_flip']:.3f}")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _f(x, fmt=".2f"):
    return "—" if x is None else format(x, fmt)


def markdown(fig5, scenes, k2, speed, fit, bowls, *, quick, size, spp, seconds,
             command) -> str:
    """The docs/results/green06.md section."""
    L = ["# Green06: view-dependent transport with nonlinear Gaussians — results", "",
         f"`{command}` ({'quick smoke run, ' if quick else ''}{seconds:.0f} s on this machine). "
         "Method and derivations: docs/GREEN06.md.", "",
         "## Fig 5: Gaussians vs nonlinear Haar vs SH at equal storage", "",
         "Relative L2 error √(Σ Ω (T̃−T)² / Σ Ω T²) over the texels of a 6×"
         f"{fig5[0]['cube'].res}² light cube (scalar transport BRDF × visibility × cosine). "
         "N Gaussians (greedy: each N refits all N from the N − 1 fit plus one start at the "
         "largest residual) against the 7N largest Haar coefficients (cube faces of T√Ω, so "
         "the truncation is optimal in this metric) and SH of the smallest full order with "
         "≥ 7N coefficients (9 = l ≤ 2 for N = 1, 81 = l ≤ 8 for N = 10; least squares on the "
         "texels). The paper counts a Gaussian as 7 floats.", "",
         "| transport function | N | Gaussians | Haar (7N) | SH (coefficients) |",
         "|---|---|---|---|---|"]
    shown = (1, 2, 3, 5, 7, 10)
    for c in fig5:
        for r in c["rows"]:
            if r["gaussians"] in shown:
                L.append(f"| {c['title']} | {r['gaussians']} | {r['gaussian']:.3f} | "
                         f"{r['haar']:.3f} | {r['sh']:.3f} ({r['sh_coefficients']}) |")
    L += ["", "One Gaussian's error is the function's, not the fit's: an exhaustive search (every "
          "axis of a 6×16² cube × 48 σ, each with its optimal weight, then least squares from "
          "the best) ends at " + ", ".join(
              f"{c['single_search']:.3f} ({c['name']}; the fit: {c['rows'][0]['gaussian']:.3f})"
              for c in fig5 if "single_search" in c) + ".", "",
          "![Fig 5](figures/green06/fig5_lobes.png)", "",
          "## Fidelity (configs/transport_floor.yaml) and Fig 6: visibility", "",
          f"A GGX α 0.15 ball (ks 0.8) on a Lambert floor, {size}², reference {spp} spp "
          "(direct lighting, box filter), real-time methods 3×3 supersampled. Display PSNR "
          "(dB) / LDR-FLIP vs the reference over the ball's surface pixels and over all "
          "surfaces (ball + floor). `transport_green06` is Green06 as published (the light "
          "cube's fit, §5's render), 1 Gaussian with visibility; `gmm` without "
          "visibility is Fig 6's prefiltering technique without visibility; `sg` uses its SSDF "
          "visibility.", "",
          "| env | method | ball PSNR | ball FLIP | surfaces PSNR | surfaces FLIP | ms/frame |",
          "|---|---|---|---|---|---|---|"]
    for env, s in scenes.items():
        if "error" in s:
            L.append(f"| {env} | all | missing: {s['error']} | | | | |")
            continue
        for m in [m for m in ("transport_green06", "sg", "gmm") if f"{m}_scores" in s]:
            sc = s[f"{m}_scores"]
            ms = s["timings"].get(f"{m}_s")
            L.append(f"| {env} | {m} | {sc['ball_psnr']:.2f} | {sc['ball_flip']:.4f} | "
                     f"{sc['surface_psnr']:.2f} | {sc['surface_flip']:.4f} | "
                     f"{_f(None if ms is None else 1e3 * ms, '.1f')} |")
    L += ["", "![Fig 6](figures/green06/fig6_visibility.png)", ""]
    L += _bowl_section(bowls, size, spp)
    L += ["## Fig 7: 1 vs 2 Gaussians (studio)", "",
          "| Gaussians | ball PSNR | ball FLIP | surfaces PSNR | surfaces FLIP | fit error |",
          "|---|---|---|---|---|---|"]
    st = scenes.get("studio", {})
    for k, s in ((1, st), (2, k2)):
        if "error" in s or "transport_green06_scores" not in s:
            L.append(f"| {k} | missing: {s.get('error', 'no reference')} | | | | |")
            continue
        sc = s["transport_green06_scores"]
        L.append(f"| {k} | {sc['ball_psnr']:.2f} | {sc['ball_flip']:.4f} | "
                 f"{sc['surface_psnr']:.2f} | {sc['surface_flip']:.4f} | "
                 f"{s['report']['ball']['fit_rel_err_mean']:.3f} |")
    L += ["", "![Fig 7](figures/green06/fig7_gaussians.png)", ""]
    L += ["## §6.1 storage and timing", ""]
    if fit is None:
        L += ["(not run with --quick)", ""]
    else:
        n = fit["model_vertices"]
        cps = fit["gaussians_per_cpu_s"]
        L += [f"Fit: the teapot ({n} vertices; GGX α 0.15, 92 views, 1 Gaussian, 6×16²), the "
              f"first {fit['sample_vertices']} vertices of the flood-fill order in one process "
              "(sampling + fit), extrapolated to the model.", "",
              "| quantity | paper (§6.1) | sgpipe |", "|---|---|---|",
              f"| storage per vertex, 1 Gaussian | 92 × 7 × 4 = {fit['paper_bytes_per_vertex']} B "
              f"| {fit['bytes_per_vertex']:.0f} B ({fit['bytes_per_vertex'] / fit['paper_bytes_per_vertex']:.3f}) |",
              f"| storage, {n} vertices | {fit['paper_bytes_per_vertex'] * n / 1e6:.1f} MB | "
              f"{fit['bytes_per_vertex'] * n / 1e6:.1f} MB |",
              f"| Gaussians fitted per CPU second (one core) | — | {cps:.0f} |",
              f"| fit of {n} vertices on 2 cores | 1–3 h on 20 machines | "
              f"{n * 92 / cps / 2:.0f} s (extrapolated) |",
              f"| mean fit error (pooled relative L2) | — | {fit['fit_rel_err']:.3f} |", ""]
    if speed is not None and "error" not in speed:
        ms = 1e3 * speed["timings"]["transport_s"]
        nv = sum(o["vertices"] for o in speed["report"].values())
        L += [f"Render speed: `transport` at 512², the floor scene with a 10 242-vertex ball "
              f"({nv} transport vertices with the floor), 1 sample per pixel: **{ms:.1f} "
              f"ms/frame = {1e3 / ms:.1f} fps** (OpenCL on the CPU, PoCL, 2 shared cores; "
              "target ≥ 5 fps).", ""]
    elif speed is not None:
        L += [f"Render speed: missing ({speed['error']})", ""]
    return "\n".join(L) + "\n"


def _bowl_section(bowls: dict, size: int, spp: int) -> list[str]:
    """Fig 6 on the concave bowl: the table under each environment."""
    if not bowls:
        return ["## Fig 6 on a concave object", "", "(not run with --quick)", ""]
    L = ["## Fig 6 on a concave object", "",
         "The fidelity corpus's thick glossy bowl (GGX α 0.08, ks 0.8), whose rim hides part "
         "of the lamps' reflections from its inner wall, "
         f"{size}², reference {spp} spp (direct lighting, box filter), 3×3 supersampled. "
         "`transport_green06` is Green06 as published, fit (transport.sampling: cube, 6×16² "
         "texel centres) and render (§5); `gmm` without visibility is Fig 6's prefiltering; "
         "`transport` and `sg` are sgpipe's (transport.sampling: lobe). Display PSNR and "
         "LDR-ꟻLIP over the bowl's pixels.", "",
         "| env | method | bowl PSNR | bowl ꟻLIP | ms/frame |", "|---|---|---|---|---|"]
    for env, s in bowls.items():
        if "error" in s:
            L.append(f"| {env} | all | missing: {s['error']} | | |")
            continue
        for m, _ in BOWL_METHODS:
            sc = s[f"{m}_scores"]
            ms = s["timings"].get(f"{m}_s")
            L.append(f"| {env} | {m} | {sc['ball_psnr']:.2f} | {sc['ball_flip']:.4f} | "
                     f"{_f(None if ms is None else 1e3 * ms, '.1f')} |")
    return L + ["", "![Fig 6 on the bowl](figures/green06/fig6_bowl.png)", ""]


def publish(results: Path, md: str, out: Path) -> None:
    """docs/results/green06.md and its figures under docs/results/figures/green06/."""
    results.parent.mkdir(parents=True, exist_ok=True)
    figs = results.parent / "figures" / "green06"
    figs.mkdir(parents=True, exist_ok=True)
    for f in FIGS:
        if (out / f).exists():
            shutil.copyfile(out / f, figs / f)
    results.write_text(md)


__all__ = ["fig5", "fig6", "fig6_bowl", "fig7", "markdown", "publish"]
