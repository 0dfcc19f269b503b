"""Wang09 Fig 8: per-vertex against per-pixel shading at several tessellation densities. A glossy
GGX ball on a floor grid under the sun-lit sky, through the real stages (fit → precompute →
render: `sg` per pixel and the reference); then the same renderer shades `sg` at the SSDF mesh's
vertices (each vertex its own exact SSDF, normal and view) and the frame interpolates those
colours over the triangles — per-vertex shading — with the same 3×3 sub-pixel G-buffers.
Surface display PSNR of both against the reference, on the floor (the ball's sun shadow) and the
ball (its highlight), per density: `measure(out)`, `figure(rows, path)`, `markdown(rows, png)`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
#: (floor grid cells per side, the ball's icosphere subdivisions of its SSDF mesh)
DENSITIES = ((4, 1), (8, 2), (16, 3), (32, 4))
SIZE, SPP, EXPOSURE = 128, 256, -1.0


def config(floor_obj: Path, subdivisions: int, *, size: int = SIZE, spp: int = SPP):
    """The ball-on-floor scene (validated root Config) at one density."""
    from sgpipe.experiments.corpus.measure import load_scene
    raw = {
        "name": "wang09-fig8", "seed": 0, "workers": 0,
        "scene": {"objects": [
            {"name": "ball", "sphere_radius": 0.5, "translate": [0, 0.5, 0], "material": "ball"},
            {"name": "floor", "mesh": str(floor_obj), "material": "floor"}]},
        "fit": {"materials": [
            {"name": "ball", "model": "ggx", "params": {"alpha": 0.12, "kd": [0.1, 0.06, 0.04],
                                                        "ks": 0.8}},
            {"name": "floor", "model": "lambert", "params": {"kd": [0.55, 0.52, 0.48]}}],
            "ndf_sg": {"report_lobes": 0}, "view_gmm": {"enabled": False}},
        "envmap": {"environment": str(ROOT / "data_samples" / "sky_sun.exr")},
        "visibility": {"sphere_subdivisions": subdivisions, "preview_vertices": 0},
        "render": {"camera": {"eye": [0, 2.2, 3.4], "target": [0, 0.3, 0], "fov_deg": 40,
                              "width": size, "height": size},
                   "methods": ["sg", "reference"], "spp": spp, "supersample": 3,
                   "preview_exposure": EXPOSURE, "timing_repeats": 1},
    }
    return load_scene(raw)


def _vertex_frame(bundle, eye: np.ndarray):
    """(Frame of every SSDF vertex of every object, per object its first row in the frame): each
    vertex shaded at its own position, normal, tangent frame (the G-buffer's rule, in which the
    SSDF is stored) and view, its SSDF taken whole (a corner of one of its triangles with
    barycentrics at that corner)."""
    from sgpipe.render.renderer import Frame
    from sgpipe.scene.gbuffer import tangent_frames    # the G-buffer's rule (CONVENTIONS)
    pos, nrm, hint, obj, tri, bary, first = [], [], [], [], [], [], []
    for k, (o, s) in enumerate(zip(bundle.objects, bundle.renderer.objects)):
        first.append(sum(len(p) for p in pos))
        v = s.vis
        proxy = bundle.proxies[k]
        if o.kind == "sphere":
            p = np.asarray(proxy.vertices, float)
            n = (p - np.asarray(o.center, float)) / np.linalg.norm(p - o.center, axis=1)[:, None]
        else:
            p = np.asarray(o.vertices, float)
            n = np.asarray(o.normals, float)
        hint.append(np.asarray(o.tangents, float) if o.kind == "mesh" and o.tangents is not None
                    else np.full((len(p), 3), np.nan))
        faces = np.asarray(v.faces)
        corner_face = np.full(len(p), -1)
        corner = np.zeros(len(p), int)
        for c in range(3):                       # one triangle per vertex, the last that has it
            corner_face[faces[:, c]] = np.arange(len(faces))
            corner[faces[:, c]] = c
        b = np.zeros((len(p), 2))
        b[corner == 1, 0] = 1.0
        b[corner == 2, 1] = 1.0
        pos.append(p), nrm.append(n), tri.append(corner_face), bary.append(b)
        obj.append(np.full(len(p), k))
    p, n, h = np.concatenate(pos), np.concatenate(nrm), np.concatenate(hint)
    # the SSDF is stored in the frame the G-buffer gives the surface: the same tangent rule
    ok = np.isfinite(h).all(1)
    t, _ = tangent_frames(n, np.where(ok[:, None], h, 0.0), ok)
    view = eye - p
    view /= np.linalg.norm(view, axis=1)[:, None]
    f4 = lambda a: np.concatenate([a, np.zeros((len(a), 1))], 1).astype(np.float32)  # noqa: E731
    m = len(p)
    tangent = f4(t)
    tangent[:, 3] = 1.0                      # handedness (no normal map here)
    fr = Frame(index=np.arange(m), shape=(m,), normal=f4(n), tangent=tangent, view=f4(view),
               position=f4(p), uv=np.zeros((m, 2), np.float32),
               obj=np.concatenate(obj).astype(np.int32),
               tri=np.concatenate(tri).astype(np.int32),
               bary=np.concatenate(bary).astype(np.float32), duv=np.zeros((m, 4), np.float32))
    return fr, first


def per_vertex_image(cfg, out: Path) -> np.ndarray:
    """`sg` shaded at the vertices and interpolated over the triangles of every sub-pixel
    G-buffer (render.supersample), averaged as the render stage averages."""
    from sgpipe.render.methods import METHODS
    from sgpipe.render.setup import build_scene
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import Tracer
    from sgpipe.stages.render import supersampled_frames
    bundle = build_scene(cfg, out, [METHODS["sg"]])
    cam = Camera.from_spec(cfg.render.camera)
    vfr, first = _vertex_frame(bundle, np.asarray(cfg.render.camera.eye, float))
    colours = bundle.renderer.shade("sg", vfr).astype(np.float64)
    acc = None
    for fr, bg in supersampled_frames(cam, Tracer(bundle.objects), bundle,
                                      cfg.render.supersample, cfg.render.background):
        rgb = np.zeros((len(fr.index), 3))
        for k, s in enumerate(bundle.renderer.objects):
            sel = (fr.obj == k) & (fr.tri >= 0)
            f = np.asarray(s.vis.faces)[fr.tri[sel]] + first[k]
            b = fr.bary[sel].astype(np.float64)
            w = np.stack([1.0 - b[:, 0] - b[:, 1], b[:, 0], b[:, 1]], -1)
            rgb[sel] = np.einsum("pc,pcx->px", w, colours[f])
        img = fr.to_image(rgb.astype(np.float32), bg).astype(np.float64)
        acc = img if acc is None else acc + img
    return acc / cfg.render.supersample ** 2


def measure(out: Path, *, densities=DENSITIES, size: int = SIZE, spp: int = SPP,
            log=print) -> list[dict]:
    """Per density: floor / ball surface display PSNR of per-pixel and per-vertex `sg`."""
    from sgpipe.artifacts.render import read_gbuffer, read_image
    from sgpipe.experiments.corpus.assets import floor_grid_mesh
    from sgpipe.io.mesh import write_obj
    from sgpipe.metrics import compare_images, surface_mask
    from sgpipe.stages import fit, precompute, render
    rows = []
    for cells, sub in densities:
        d = Path(out) / f"cells{cells}"
        d.mkdir(parents=True, exist_ok=True)
        v, f, n = floor_grid_mesh(size=4.0, cells=cells)
        write_obj(d / "floor.obj", v, f, normals=n)
        cfg = config(d / "floor.obj", sub, size=size, spp=spp)
        for stage in (fit, precompute, render):
            stage.run(cfg, d)
        rd = d / "render"
        gb = read_gbuffer(rd)
        ref = read_image(rd, "reference")
        images = {"per pixel": read_image(rd, "sg"), "per vertex": per_vertex_image(cfg, d)}
        row = {"cells": cells, "subdivisions": sub, "images": images, "reference": ref}
        for part, k in (("ball", 0), ("floor", 1)):
            mask = surface_mask(gb.object_id) & (gb.object_id == k)
            for name, img in images.items():
                c = compare_images(img, ref, exposure=EXPOSURE, surface=mask)
                row[f"{name} {part}"] = c["surface"]["display_psnr_db"]
        rows.append(row)
        log(f"[wang09 fig8] {cells}² floor cells, ball subdivisions {sub}: "
            + ", ".join(f"{k} {row[k]:.2f}" for k in row if k.endswith(("ball", "floor"))))
    return rows


def figure(rows: list[dict], path: Path) -> None:
    """Rows: densities; columns: reference, per-pixel sg, per-vertex sg."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from sgpipe.metrics.display import display_image
    fig, ax = plt.subplots(len(rows), 3, figsize=(9, 3 * len(rows)))
    ax = np.atleast_2d(ax)
    for r, row in enumerate(rows):
        panels = [("reference", row["reference"], "")]
        panels += [(name, row["images"][name],
                    f"\nball {row[f'{name} ball']:.1f} dB, floor {row[f'{name} floor']:.1f} dB")
                   for name in ("per pixel", "per vertex")]
        for c, (name, img, note) in enumerate(panels):
            ax[r, c].imshow(display_image(img, exposure=EXPOSURE))
            ax[r, c].set_title(f"{row['cells']}² floor cells, subdiv {row['subdivisions']}: "
                               f"{name}{note}", fontsize=7)
            ax[r, c].axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def markdown(rows: list[dict], png: str) -> list[str]:
    """The results page's Fig 8 section."""
    out = ["### Fig 8: per-vertex vs per-pixel shading", "",
           "A GGX α 0.12 ball (its SSDF on an icosphere of the given subdivisions) on a 4 × 4 "
           "floor grid of the given cells under the sun-lit sky, "
           f"{SIZE}², 3×3 supersampled, reference {SPP} spp. Per pixel: `sg` as it renders "
           "(each pixel's SSDF interpolated from the vertices' PCA coefficients). Per vertex: "
           "`sg` shaded at the SSDF mesh's vertices and the colours interpolated over the "
           "triangles. Surface display PSNR (dB).", "",
           "| floor cells | ball subdivisions | per pixel: ball | per vertex: ball | "
           "per pixel: floor | per vertex: floor |", "|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['cells']}² | {r['subdivisions']} | {r['per pixel ball']:.2f} | "
                   f"{r['per vertex ball']:.2f} | {r['per pixel floor']:.2f} | "
                   f"{r['per vertex floor']:.2f} |")
    return out + ["", f"![Fig 8]({png})", ""]
