"""Textured glTF materials against the reference: the sample asset (data_samples/
textured_ball.glb: base colour, roughness 0.05–0.8, sharp metal bands, a normal texture of
round bumps) and a plane seen at 50° from its normal carrying the same textures, the base-colour
and metallic-roughness textures minified k = 1, 2, 4, 8 and 16 times (KHR_texture_transform
scale k, samplers repeating: k² times the texels under each pixel), rendered under the studio
map by `sg`, `fis` and `gmm` (per-pixel parameters from the MIP-filtered textures), by the
Han07 normal-map methods (the normal texture as filtered pyramids), by `transport` and
`transport_green06` (with the visibility and transport stages, in a run of their own;
per-vertex materials filtered to the vertex spacing) and by the Monte Carlo `reference` (the
unfiltered textures at each sample's hit); the asset without its normal texture (`smooth`:
the textured parameters alone); as a control, a sphere in uniform metal and dielectric
materials of roughness 0.1–0.9; and gmm's error, fit time and storage against its count of
roughness entries (fit.view_gmm_rough).

    python -m sgpipe.experiments.gltf_textures --out out/figures/gltf_textures \\
        --results docs/results/gltf_textures.md

Surface display PSNR against the mean of two references of different seeds; the floor column
is the two references against each other plus 6 dB (the noise of their mean, approximately).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
ASSET = ROOT / "data_samples" / "textured_ball.glb"
STUDIO = ROOT / "data_samples" / "studio.exr"
SPHERE = ROOT / "data_samples" / "sphere.obj"
#: sg also rendered at this many times the size per side and box-averaged down: how much of
#: its error is the sub-pixel variation of what it reads unfiltered (the normal texture)
SUPERSAMPLE = 4
#: the uniform control spheres: metallic × roughness, in a mid paint colour
UNIFORM_METALLIC = (1.0, 0.0)
UNIFORM_ROUGHNESS = (0.1, 0.3, 0.5, 0.7, 0.9)
UNIFORM_BASE = (0.9, 0.6, 0.3)
MINIFICATIONS = (1, 2, 4, 8, 16)
METHODS = ("sg", "fis", "gmm")
#: the Han07 methods, in the main run with a `normalmap:` section (the asset's normal texture
#: as pyramids; no effect on the other methods)
NM_METHODS = ("vmf", "vmf_han07", "normals_mip", "toksvig", "engine_bake", "nm_sh")
#: the other papers as published, in the main run too (nm_sh_han07 not on the uniform controls:
#: §5's l* = ⌈√(4s)⌉ of a glossy GGX factor is beyond the SH orders it renders)
PUBLISHED = ("sg_wang09", "gmm_toral19", "nm_sh_han07")
#: the Green06 methods, in a run of their own with the visibility and transport stages (the
#: other methods' runs stay without SSDF shadows)
TRANSPORT_METHODS = ("transport", "transport_green06")
TRANSPORT_STAGES = ("visibility: {trace_resolution: 64, resolution: 16, pca_terms: 16}\n"
                    "transport: {report_vertices: 0}\n")
GOAL_DB = 33.0
#: gmm on the textured subjects within this of its mean on the uniform controls of the
#: textures' roughness range (UNIFORM_ROUGHNESS up to the asset's 0.8)
GMM_GOAL_DB = 1.0
TEXTURE_ROUGHNESS_MAX = 0.8
#: gmm's roughness entries (fit.view_gmm.roughness_entries) measured on `smooth` 1×
ENTRY_COUNTS = (1, 2, 4, 8, 16, 32)
CAMERAS = {"ball": "{eye: [0, 0.8, 3.6], target: [0, 0, 0], fov_deg: 36",
           "plane": "{eye: [0, 2.3, 1.93], target: [0, 0, 0], fov_deg: 50"}
CAMERAS["uniform"] = CAMERAS["smooth"] = CAMERAS["ball"]


def _plane(doc) -> None:
    """Replace the asset's mesh by a 2 × 2 quad in y = 0 facing +y, UVs 0–1 (its binary blob
    extended with the new accessors)."""
    import pygltflib as g
    blob = bytearray(doc.binary_blob())
    p = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
    n = np.tile(np.float32([0, 1, 0]), (4, 1))
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    idx = np.array([0, 3, 2, 0, 2, 1], np.uint16)

    def add(arr, comp, typ, target):
        blob.extend(b"\0" * (-len(blob) % 4))
        doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(blob),
                                            byteLength=arr.nbytes, target=target))
        blob.extend(np.ascontiguousarray(arr).tobytes())
        acc = g.Accessor(bufferView=len(doc.bufferViews) - 1, componentType=comp,
                         count=len(arr), type=typ)
        if typ == g.VEC3:
            acc.min, acc.max = arr.min(0).tolist(), arr.max(0).tolist()
        doc.accessors.append(acc)
        return len(doc.accessors) - 1

    prim = doc.meshes[0].primitives[0]
    prim.attributes = g.Attributes(POSITION=add(p, g.FLOAT, g.VEC3, g.ARRAY_BUFFER),
                                   NORMAL=add(n, g.FLOAT, g.VEC3, g.ARRAY_BUFFER),
                                   TEXCOORD_0=add(uv, g.FLOAT, g.VEC2, g.ARRAY_BUFFER))
    prim.indices = add(idx, g.UNSIGNED_SHORT, g.SCALAR, g.ELEMENT_ARRAY_BUFFER)
    blob.extend(b"\0" * (-len(blob) % 4))
    doc.buffers[0].byteLength = len(blob)
    doc.set_binary_blob(bytes(blob))


def write_variant(subject: str, k: int, path: Path) -> Path:
    """The asset (or the plane with its textures) minified k times."""
    import pygltflib as g
    doc = g.GLTF2().load(str(ASSET))
    if subject == "plane":
        _plane(doc)
    if subject == "smooth":
        doc.materials[0].normalTexture = None
    pbr = doc.materials[0].pbrMetallicRoughness
    for info in (pbr.baseColorTexture, pbr.metallicRoughnessTexture):
        info.extensions = {"KHR_texture_transform": {"scale": [float(k), float(k)]}}
    doc.extensionsUsed = sorted(set(doc.extensionsUsed or []) | {"KHR_texture_transform"})
    for s in doc.samplers or []:
        s.wrapS = s.wrapT = g.REPEAT
    path.parent.mkdir(parents=True, exist_ok=True)
    doc.save_binary(str(path))
    return path


def _config(glb: Path | None, subject: str, size: int, spp: int, seed: int, methods,
            uniform: tuple[float, float] | None = None, scale: int = 1,
            entries: int | None = None) -> str:
    """One run's config: the glTF file, or (uniform = (metallic, roughness)) the unit sphere in
    a uniform gltf_pbr material of the asset's mean paint colour; gmm's fit with `entries`
    roughness entries (None: the default)."""
    if "gmm" in methods:
        extra = "" if entries is None else f", roughness_entries: {entries}"
        gmm = f"view_gmm: {{report_lobes: 0, holdout: false{extra}}}"
    else:
        gmm = "view_gmm: {enabled: false}"
    if uniform is None:
        scene = f"scene: {{gltf: [{{file: {glb}}}]}}\nfit: {{{gmm}}}"
    else:
        scene = (f"scene: {{objects: [{{name: ball, mesh: {SPHERE}, material: paint}}]}}\n"
                 f"fit:\n  {gmm}\n  materials: [{{name: paint, "
                 f"model: gltf_pbr, params: {{base_color: {list(UNIFORM_BASE)}, metallic: "
                 f"{uniform[0]}, roughness: {uniform[1]}}}}}]")
    nm = "normalmap: {}\n" if set(methods) & set(NM_METHODS + PUBLISHED[2:]) else ""
    return f"""name: gltf_textures
seed: {seed}
{scene}
{nm}envmap: {{environment: {STUDIO}, cube_resolution: 64}}
render:
  camera: {CAMERAS[subject]}, width: {size * scale}, height: {size * scale}}}
  methods: [{', '.join(methods)}]
  environment_exposure: -2.0
  preview_exposure: 0.0
  spp: {spp}
"""


def _run(cfg_text: str, work: Path, tag: str) -> Path:
    cfg = work / f"{tag}.yaml"
    cfg.write_text(cfg_text)
    out = work / tag
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(cfg), "--out", str(out)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"sgpipe run {cfg} failed:\n{r.stderr[-3000:]}")
    return out / "render"


def measure(subject: str, k: int, work: Path, *, size: int, spp: int,
            uniform: tuple[float, float] | None = None) -> dict:
    """Surface display PSNR of each method against the two references' mean, the floor, and
    each method's frame time: the subject minified k times, or the uniform control sphere."""
    from sgpipe.io import read_exr
    from sgpipe.metrics import display_psnr, surface_mask
    if uniform is None:
        glb, tag = write_variant(subject, k, work / f"{subject}_{k}x.glb"), f"{subject}_{k}x"
    else:
        glb, tag = None, f"uniform_m{uniform[0]:g}_r{uniform[1]:g}"
    pub = PUBLISHED if uniform is None else PUBLISHED[:2]
    a = _run(_config(glb, subject, size, spp, 1, (*METHODS, *NM_METHODS, *pub, "reference"),
                     uniform), work, f"{tag}_a")
    b = _run(_config(glb, subject, size, spp, 2, ("reference",), uniform), work, f"{tag}_b")
    ra, rb = (read_exr(d / "reference.exr")[..., :3] for d in (a, b))
    ref = 0.5 * (ra + rb)
    mask = surface_mask(np.load(a / "gbuffer.npz", allow_pickle=False)["object_id"])
    timings = json.loads((a / "timings.json").read_text())
    row = {"subject": subject, "minification": k,
           "floor_db": display_psnr(ra, rb, mask=mask) + 6.02}
    if uniform is not None:
        row.update(metallic=uniform[0], roughness=uniform[1])
    for m in METHODS + NM_METHODS + pub:
        row[m] = {"surface_display_psnr_db": display_psnr(read_exr(a / f"{m}.exr")[..., :3],
                                                          ref, mask=mask),
                  "frame_ms": 1e3 * timings[f"{m}_s"]}
    text = _config(glb, subject, size, spp, 1, TRANSPORT_METHODS, uniform)
    t = _run(text.replace("envmap:", TRANSPORT_STAGES + "envmap:"), work, f"{tag}_tp")
    t_ms = json.loads((t / "timings.json").read_text())
    rep = json.loads((t.parent / "transport" / "report.json").read_text())["objects"]
    row["transport_vertices"] = sum(o["vertices"] for o in rep.values())
    for m in TRANSPORT_METHODS:
        row[m] = {"surface_display_psnr_db": display_psnr(read_exr(t / f"{m}.exr")[..., :3],
                                                          ref, mask=mask),
                  "frame_ms": 1e3 * t_ms[f"{m}_s"]}
    if uniform is None and subject != "smooth":
        s = _run(_config(glb, subject, size, spp, 1, ("sg",), scale=SUPERSAMPLE), work,
                 f"{tag}_ss")
        big = read_exr(s / "sg.exr")[..., :3]
        small = big.reshape(size, SUPERSAMPLE, size, SUPERSAMPLE, 3).mean((1, 3))
        row["sg_supersampled_db"] = display_psnr(small, ref, mask=mask)
    return row


def entry_sweep(work: Path, *, size: int, spp: int) -> list[dict]:
    """gmm on `smooth` 1× (after `measure` rendered its references) for each of ENTRY_COUNTS
    roughness entries: surface display PSNR, the entries' fit time and stored bytes."""
    from sgpipe.io import read_exr
    from sgpipe.metrics import display_psnr, surface_mask
    glb = work / "smooth_1x.glb"
    ra, rb = (read_exr(work / f"smooth_1x_{s}" / "render" / "reference.exr")[..., :3]
              for s in "ab")
    ref = 0.5 * (ra + rb)
    mask = surface_mask(np.load(work / "smooth_1x_a" / "render" / "gbuffer.npz",
                                allow_pickle=False)["object_id"])
    rows = []
    for n in ENTRY_COUNTS:
        d = _run(_config(glb, "smooth", size, spp, 1, ("gmm",), entries=n), work,
                 f"smooth_entries{n}").parent
        fit_t = json.loads((d / "fit" / "timings.json").read_text())
        mat = json.loads((d / "fit" / "materials.json").read_text())["materials"][0]
        grid = json.loads((d / "fit" / mat / "report.json").read_text())["view_gmm"]
        rows.append({"entries": n, "gmm_db": display_psnr(
            read_exr(d / "render" / "gmm.exr")[..., :3], ref, mask=mask),
            "fit_s": fit_t.get(f"{mat}.view_gmm_rough_s", 0.0),
            "factor_fit_s": fit_t[f"{mat}.view_gmm_s"] - fit_t.get(f"{mat}.view_gmm_rough_s",
                                                                    0.0),
            "bytes": grid["roughness_grid"]["bytes"]})
    return rows


def main(argv=None) -> int:
    from sgpipe.experiments.gltf_textures_report import report
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("out/figures/gltf_textures"))
    ap.add_argument("--results", type=Path, default=None, help="Markdown page to write")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=512)
    ap.add_argument("--subjects", nargs="+", default=["ball", "smooth", "plane", "uniform"],
                    help="ball, smooth, plane (minified) and uniform (the control spheres)")
    ap.add_argument("--minifications", nargs="+", type=int, default=list(MINIFICATIONS))
    a = ap.parse_args(argv)
    a.out = a.out.resolve()     # the configs name their glTF files by absolute path
    a.out.mkdir(parents=True, exist_ok=True)
    rows = []
    jobs = [(s, k, None) for s in a.subjects if s != "uniform" for k in a.minifications]
    if "uniform" in a.subjects:
        jobs += [("uniform", 1, (m, r)) for m in UNIFORM_METALLIC for r in UNIFORM_ROUGHNESS]
    for subject, k, uniform in jobs:
        row = measure(subject, k, a.out, size=a.size, spp=a.spp, uniform=uniform)
        rows.append(row)
        what = f"{k}x" if uniform is None else f"metallic {uniform[0]:g} roughness {uniform[1]:g}"
        print(f"[gltf_textures] {subject} {what}: " + ", ".join(
            f"{m} {row[m]['surface_display_psnr_db']:.2f} dB"
            for m in METHODS + NM_METHODS + TRANSPORT_METHODS)
            + f" (floor {row['floor_db']:.1f})",
            flush=True)
    sweep = None
    if "smooth" in a.subjects and 1 in a.minifications:
        sweep = entry_sweep(a.out, size=a.size, spp=a.spp)
        for r in sweep:
            print(f"[gltf_textures] gmm with {r['entries']} roughness entries: "
                  f"{r['gmm_db']:.2f} dB, fit {r['fit_s']:.1f} s", flush=True)
    data = {"rows": rows, "entry_sweep": sweep}
    (a.out / "gltf_textures.json").write_text(json.dumps(data, indent=1))
    if a.results is not None:
        a.results.parent.mkdir(parents=True, exist_ok=True)
        a.results.write_text(report(rows, a.size, a.spp, sweep))
        a.results.with_suffix(".json").write_text(json.dumps(data, indent=1))
        print(f"[gltf_textures] wrote {a.results}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
