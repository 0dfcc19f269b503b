"""Han07's texel-level experiments for `sgpipe.experiments.han07`: Fig 7 (one coarse texel's NDF
against its J-lobe vMF fit, J = 1…8) and Fig 3's Lambertian SH (l ≤ 2, eq 12 with ρ̂_l of the
clamped cosine) per MIP level, plus Fig 3's receding-plane render when `nm_sh` is registered."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data_samples"
FIG7_LOBES = tuple(range(1, 9))
FIG7_EXPONENT = 60.0             # the Fig 2 material's Blinn–Phong s
FIG7_LIGHT = (45.0, 30.0)        # lit sphere: light 45° from the viewer, azimuth 30°
FIG7_SIZE = 96
SH_LMAX = 8                      # band limit of the NDF error
FIG3_LIGHTS = (30.0, 60.0, 80.0)  # polar angles of the Lambertian light (azimuth 30°)


def sample_normals(name: str) -> np.ndarray:
    """The decoded unit normals of data_samples/<name> (as the renderer reads them)."""
    from sgpipe.normalmap.read import read_normal_map
    return read_normal_map(DATA / name, f"data_samples/{name}")


def fig7_pieces(full: bool) -> list[tuple[str, np.ndarray]]:
    """(label, normals) whose pyramid root is Fig 7's texel: one 64² cell of the grooves map
    (a level-6 texel: one groove pair and one cap) and, in the full run, the bumps map's cell
    and both whole maps (the level-8 texel)."""
    g = sample_normals("grooves_normal.png")
    out = [("grooves cell (level 6)", np.ascontiguousarray(g[:64, :64]))]
    if full:
        b = sample_normals("normal_map.png")
        out += [("bumps cell (level 6)", np.ascontiguousarray(b[:64, :64])),
                ("grooves map (level 8)", g), ("bumps map (level 8)", b)]
    return out


def fig7_curve(normals: np.ndarray, lobes=FIG7_LOBES, *, size: int = FIG7_SIZE) -> dict:
    """Per lobe count J: the root texel's lobes as the vMF pyramid stores them (aligned,
    default settings), their NDF error (l ≤ SH_LMAX) and the lit-sphere image error (relative
    L2, display PSNR, LDR-ꟻLIP) of the effective Blinn–Phong BRDF against the texel's exact one.
    Returns {"rows": [...], "truth": image, "images": {J: image}}."""
    from sgpipe.metrics import compare_images
    from sgpipe.normalmap import quality as Q
    from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid, mixture_blinn_phong, \
        texel_lobes
    mask, h_loc, cos = Q.lit_sphere_half_vectors(size, FIG7_LIGHT)
    truth_v = Q.texel_blinn_phong(normals, FIG7_EXPONENT, h_loc) * cos
    scale = 1.0 / truth_v.max()

    def image(vals):
        img = np.zeros((size, size, 3), np.float32)
        img[mask] = (vals * scale)[:, None]
        return img

    truth = image(truth_v)
    rows, images = [], {}
    for j in lobes:
        pyr = fit_vmf_pyramid(normals, VMFSettings(lobes=j))
        lev = len(pyr.alpha) - 1
        al, mu, ka = texel_lobes(pyr, lev, 0, 0)
        vals = mixture_blinn_phong(al, mu, ka, FIG7_EXPONENT, h_loc) * cos
        img = image(vals)
        d = compare_images(img, truth, mask=mask)
        rows.append({"lobes": j, "ndf_error": Q.ndf_sh_error(normals, al, mu, ka, SH_LMAX),
                     "image_rel_l2": float(np.linalg.norm(vals - truth_v)
                                           / np.linalg.norm(truth_v)),
                     "image_psnr": d["display_psnr_db"], "image_flip": d["flip_ldr"],
                     "used_lobes": int((al > 0).sum())})
        images[j] = img
    return {"rows": rows, "truth": truth, "images": images}


def fig7(out: Path, *, full: bool, log=print) -> dict:
    """Fig 7's curves for every piece, its plot and the lit-sphere strip (first piece)."""
    from sgpipe.io import tonemap_srgb, write_png
    res, pngs = {}, []
    strip = None
    for label, normals in fig7_pieces(full):
        c = fig7_curve(normals)
        res[label] = c["rows"]
        log(f"[han07] Fig 7 {label}: " + ", ".join(
            f"J={r['lobes']} NDF {r['ndf_error']:.3f} image {r['image_psnr']:.1f} dB"
            for r in c["rows"]))
        if strip is None:
            tiles = [c["truth"]] + [c["images"][j] for j in FIG7_LOBES]
            gap = np.ones((FIG7_SIZE, 2, 3), np.float32)
            strip = np.concatenate(sum([[tonemap_srgb(t).astype(np.float32) / 255, gap]
                                        for t in tiles], [])[:-1], axis=1)
            write_png(out / "han07_fig7_spheres.png", (strip * 255).round().astype(np.uint8),
                      already_8bit=True)
            pngs.append("han07_fig7_spheres.png")
    _plot_fig7(out / "han07_fig7.png", res)
    pngs.append("han07_fig7.png")
    return {"rows": res, "pngs": pngs}


def _plot_fig7(path: Path, res: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.4), dpi=100)
    for label, rows in res.items():
        j = [r["lobes"] for r in rows]
        ax[0].plot(j, [r["ndf_error"] for r in rows], "o-", label=label)
        ax[1].plot(j, [r["image_psnr"] for r in rows], "o-", label=label)
    ax[0].set(xlabel="vMF lobes J", ylabel=f"NDF rel. L2 error (l ≤ {SH_LMAX})", yscale="log")
    ax[1].set(xlabel="vMF lobes J", ylabel="lit-sphere display PSNR (dB)")
    ax[0].legend(fontsize=7)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    # fixed metadata: the same curves give the same bytes
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)


# -- Fig 3 -------------------------------------------------------------------------------------

def lambert_sh_errors(normals: np.ndarray, polar_deg: float, lmax: int = 2) -> dict:
    """Per MIP level the relative RMS over texels of the Lambertian shading max(n·l, 0) averaged
    over each texel's normals (the truth) against eq 12 with l ≤ lmax (ρ̂_l of the clamped
    cosine; Han07 §5's 9 coefficients) and against the normalised MIP normal."""
    from sgpipe.core.sh import sh_eval, sh_expand_bands
    from sgpipe.normalmap.pyramid import box_down, mean_normal_pyramid, normalized_mip
    from sgpipe.normalmap.quality import rel_rms
    from sgpipe.normalmap.sh import lambert_coeffs, ndf_sh_pyramid
    th, az = math.radians(polar_deg), math.radians(30.0)
    li = np.array([math.sin(th) * math.cos(az), math.sin(th) * math.sin(az), math.cos(th)])
    w = sh_expand_bands(lambert_coeffs(lmax)) * sh_eval(li[None], lmax)[0]
    truth = [np.maximum(normals @ li, 0.0)]
    gam = ndf_sh_pyramid(normals, lmax)
    for _ in range(1, len(gam)):
        truth.append(box_down(truth[-1]))
    mean = mean_normal_pyramid(normals)
    return {"sh": [rel_rms(g @ w, t) for g, t in zip(gam, truth)],
            "normals_mip": [rel_rms(np.maximum(normalized_mip(m) @ li, 0.0), t)
                            for m, t in zip(mean, truth)]}


def fig3_ndf(*, full: bool) -> dict:
    """{map: {polar angle: lambert_sh_errors}} (grooves only in the quick run)."""
    maps = ("grooves_normal.png", "normal_map.png") if full else ("grooves_normal.png",)
    return {name: {f"{p:g}": lambert_sh_errors(sample_normals(name), p) for p in FIG3_LIGHTS}
            for name in maps}


def fig3_render(out: Path, *, size: int = 96, spp: int = 256, log=print) -> dict:
    """Fig 3's receding plane (grooves map tiled 8×, Lambertian, camera 12° above the plane)
    rendered by `nm_sh`, `normals_mip` and the reference; {"rows", "pngs"} or {"missing"}."""
    from sgpipe.experiments import han07 as H
    from sgpipe.experiments.sheets import contact_sheet
    from sgpipe.render.methods import METHODS
    if "nm_sh" not in METHODS:
        return {"missing": "`nm_sh` is not registered in sgpipe/render/methods.py", "rows": None,
                "pngs": []}
    mesh = H.tiled_obj(DATA / "floor.obj", out / "meshes" / "plane_receding.obj", 8.0, 8.0)
    scene = {"mesh": str(mesh), "light": (0.3, 0.8, -0.5),
             "camera": {"eye": [0.0, 0.7, 3.0], "target": [0.0, 0.0, -1.5],
                        "up": [0.0, 1.0, 0.0], "fov_deg": 40.0, "width": size,
                        "height": size}}
    mat = {"name": "matte", "model": "lambert", "params": {"kd": 0.8}}
    methods = ["nm_sh", "normals_mip", "reference"]
    r = H.render(H.build_config(scene, DATA / "grooves_normal.png", methods, lobes=4, spp=spp,
                                material=mat, light_scale=2.0), out / "runs" / "fig3")
    if "error" in r:
        log(f"[han07] Fig 3 render failed: {r['error']}")
        return {"missing": r["error"], "rows": None, "pngs": []}
    cell = {"reference": {"image": r["reference"]}}
    for m in methods[:-1]:
        cell[m] = H._score(r[m], r["reference"], r["_mask"])
    # the far half of the frame (upper rows: the plane recedes towards the horizon)
    far = r["_mask"].copy()
    far[size // 2:] = False
    rows = {m: {"psnr": cell[m]["psnr"], "flip": cell[m]["flip"],
                "psnr_far": H._score(r[m], r["reference"], far)["psnr"]}
            for m in methods[:-1]}
    contact_sheet(out / "han07_fig3.png", [("receding", cell)], methods[:-1])
    log("[han07] Fig 3: " + ", ".join(f"{m} {v['psnr']:.2f} dB (far half {v['psnr_far']:.2f})"
                                      for m, v in rows.items()))
    return {"rows": rows, "pngs": ["han07_fig3.png"]}


if __name__ == "__main__":       # quick look at Fig 7's first piece
    for row in fig7_curve(fig7_pieces(False)[0][1])["rows"]:
        print(row, file=sys.stderr)
