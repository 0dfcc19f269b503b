"""Write the export folder of a run (`sgpipe export RUN_DIR`): read the envmap, visibility and
normalmap artifacts, build the specular mips (sgpipe.export.prefilter), write KTX2, DDS, SH9
JSON, glTF and the normal-map textures into a staging folder beside the target that replaces
it only when complete (a bad input or a failure leaves nothing half-written; a previous
export stays as it was)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

import sgpipe
from sgpipe.artifacts import envmap as env_art
from sgpipe.artifacts import visibility as vis_art
from sgpipe.errors import BadInput
from sgpipe.export import dds, env_rotation, green06, gltf, ktx2, normalmaps, prefilter, sh9
from sgpipe.io.atomic import atomic_folder, file_hash

MARKER = ".sgpipe-export"           # marks a folder this command wrote (safe to replace)
KTX2_FILE, DDS_FILE = "environment.ktx2", "environment.dds"
SH9_FILE, GLTF_FILE, BIN_FILE, INFO_FILE = ("irradiance_sh9.json", "scene.gltf", "scene.bin",
                                            "export.json")
GLTF_MIN_FACE = 16                  # the extension's smallest specular mip (its "say, 16x16")
ROUGHNESS_KEY = "sgpipe.roughnessMapping"
ROUGHNESS_TEXT = ("roughness = level / (levelCount - 1); GGX alpha = roughness^2; level = "
                  "split-sum GGX prefilter (n = v = r) of the radiance: integral of "
                  "L(l) D(h) max(n.l, 0) dl / integral of D(h) max(n.l, 0) dl")


def default_out(run_dir: Path) -> Path:
    return Path(run_dir) / "export"


def _log(msg: str) -> None:
    print(msg, flush=True)


def check_format(fmt: str) -> ktx2.KtxFormat:
    if fmt not in ktx2.FORMATS:
        raise BadInput(f"unknown KTX2 format {fmt!r}; one of {', '.join(ktx2.FORMATS)}",
                       key="--format")
    return ktx2.FORMATS[fmt]


def check_size(size: int | None, source_res: int) -> int:
    """Base face size: the source's N by default, else N/2^k."""
    if size is None:
        return source_res
    n = source_res
    while n > size and n % 2 == 0:
        n //= 2
    if n != size:
        raise BadInput(f"face size {size} is not the source's {source_res} divided by a power "
                       "of two", key="--size")
    return size


def load_objects(vis_dir: Path) -> list[gltf.VertexObject]:
    """Every object folder of `visibility/` (sorted by name); none when the folder is absent."""
    if not vis_dir.is_dir():
        return []
    objs = []
    for d in sorted(p for p in vis_dir.iterdir() if (p / vis_art.GEOMETRY).is_file()):
        g = vis_art.read_geometry(vis_dir, d.name)
        s = vis_art.read_ssdf_pca(vis_dir, d.name)
        if len(s.coeffs) != len(g.positions):
            raise BadInput(f"coeffs has {len(s.coeffs)} vertices, geometry.npz "
                           f"{len(g.positions)}", file=d / vis_art.SSDF_PCA,
                           key=f"visibility.{d.name}")
        z = np.load(d / vis_art.GEOMETRY, allow_pickle=False)
        has_uvs = bool(int(np.asarray(z.get("has_uvs", 0)).reshape(-1)[0])) if "has_uvs" in z \
            else g.uvs is not None
        objs.append(gltf.VertexObject(
            d.name, g.positions, g.normals, g.faces, g.tangents,
            g.uvs if has_uvs else None, s.coeffs, s.mean, s.basis, s.max_distance))
    return objs


def _check_target(out_dir: Path) -> None:
    if out_dir.exists() and not out_dir.is_dir():
        raise BadInput("exists and is not a folder", file=out_dir, key="--out")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not (out_dir / MARKER).is_file():
        raise BadInput("folder exists and is not an sgpipe export (it would be replaced); "
                       "choose another --out", file=out_dir, key="--out")


def _inputs(run_dir: Path) -> dict:
    """Content hashes of the artifacts read, keyed by their path in the run folder."""
    env = run_dir / env_art.KEY
    files = [env / env_art.PYRAMID_INDEX, env / env_art.LIGHT_SH, env / env_art.RAW_LEVEL]
    files += sorted((env / "pyramid").glob("*.exr"))
    nm = run_dir / "normalmap"
    for name in normalmaps.map_names(nm):
        files += [p for p in (nm / name / "vmf.npz", nm / name / "baselines.npz") if p.is_file()]
    tr = run_dir / "transport"
    if tr.is_dir():
        files += [p for pat in ("*/gaussians.npz", "*/sh_transfer.npz", "*/geometry.npz")
                  for p in sorted(tr.glob(pat))]
    vis = run_dir / "visibility"
    if vis.is_dir():
        files += sorted(vis.glob(f"*/{vis_art.GEOMETRY}")) + sorted(
            vis.glob(f"*/{vis_art.SSDF_PCA}"))
    return {p.relative_to(run_dir).as_posix(): file_hash(p) for p in sorted(set(files))}


def build(run_dir: Path, staging: Path, fmt: ktx2.KtxFormat, size: int | None) -> dict:
    """Read the run, write every export file into `staging`; returns export.json's content."""
    from sgpipe.envmap.store import load_pyramid
    env = run_dir / env_art.KEY
    arts = env_art.read_pyramid(env)
    if arts.raw is None:
        raise BadInput("file not found (the export's roughness-0 level is the source map)",
                       file=env / env_art.RAW_LEVEL, key=env_art.KEY)
    pyr = load_pyramid(env)
    sh = sh9.sh9_document(env)
    rot, rot_spec, rot_file = env_rotation.read_rotation(run_dir)
    light_irradiance = np.asarray(sh["irradiance"])     # the light's: map space, like its images
    if rot is not None:
        sh = env_rotation.rotate_sh9_document(sh, rot, rot_spec)
    objects = load_objects(run_dir / "visibility")
    transport = green06.load_transport(run_dir / "transport")
    source_res = arts.raw.shape[1] - 2 * env_art.SAMPLE_BORDER
    size = check_size(size, source_res)

    def progress(what):
        def report(m, count, lv):
            how = {"source": "the source map", "direct": "direct GGX quadrature",
                   "pyramid": "Γ_L pyramid, 4-SG GGX fit"}[lv.method]
            n = lv.faces.shape[1]
            _log(f"[export] {what} mip {m + 1}/{count}: {n}x{n}, roughness {lv.roughness:.3f} "
                 f"(α {lv.alpha:.4f}) from {how}")
        return report
    levels = prefilter.specular_levels(arts, pyr, size, progress("cubemap"))
    meta = {"KTXwriter": f"sgpipe {sgpipe.__version__}", ROUGHNESS_KEY: ROUGHNESS_TEXT}
    (staging / KTX2_FILE).write_bytes(ktx2.write_ktx2([lv.faces for lv in levels], fmt, meta))
    (staging / DDS_FILE).write_bytes(dds.write_dds([lv.faces for lv in levels]))
    (staging / SH9_FILE).write_text(json.dumps(sh, indent=2) + "\n")

    # the extension's chain: its own roughness spacing over the mips it lists (size … 16)
    g_min = min(GLTF_MIN_FACE, size)
    g_levels = prefilter.specular_levels(arts, pyr, size, progress("glTF IBL"), min_size=g_min)
    uris = []
    from sgpipe.io.png import write_png
    for m, lv in enumerate(g_levels):
        row = []
        for f in range(6):
            uri = f"ibl/specular_{m:02d}_{f}.png"
            (staging / "ibl").mkdir(exist_ok=True)
            write_png(staging / uri, gltf.face_image(lv.faces[f]), already_8bit=True)
            row.append(uri)
        uris.append(row)
    doc, blob = gltf.build_gltf(objects, irradiance=light_irradiance,
                                specular_uris=uris, specular_size=size, bin_uri=BIN_FILE,
                                transport=transport, rotation=rot)
    (staging / BIN_FILE).write_bytes(blob)
    (staging / GLTF_FILE).write_text(doc.to_json(indent=1) + "\n")
    normal_maps = normalmaps.export_normal_maps(run_dir / "normalmap", staging)
    inputs = _inputs(run_dir)
    extra = {}
    if rot is not None:     # only then: an unturned export stays byte-identical
        inputs[rot_file.relative_to(run_dir).as_posix()] = file_hash(rot_file)
        extra["environment_rotation"] = {
            **rot_spec, "matrix": rot.tolist(), "config": rot_file.relative_to(run_dir).as_posix(),
            "carried_by": ["scene.gltf: EXT_lights_image_based rotation (quaternion of R)",
                           f"{SH9_FILE}: irradiance / radiance of the turned environment"],
            "map_space": [KTX2_FILE, DDS_FILE, "ibl/*.png",
                          "scene.gltf: irradianceCoefficients (turned by the light's rotation)"]}
    return {**extra, "sgpipe_version": sgpipe.__version__, "run_dir_inputs": inputs,
            "ktx2": {"file": KTX2_FILE, "vk_format": fmt.name, "levels": len(levels),
                     "roughness_mapping": ROUGHNESS_TEXT},
            "dds": {"file": DDS_FILE, "dxgi_format": "R16G16B16A16_FLOAT",
                    "levels": len(levels)},
            "cubemap_levels": [lv.describe() for lv in levels],
            "gltf": {"file": GLTF_FILE, "objects": [o.name for o in objects],
                     "green06_objects": [t.name for t in transport],
                     "ibl_levels": [lv.describe() for lv in g_levels]},
            "sh9": {"file": SH9_FILE}, "normal_maps": normal_maps}


def write_export(run_dir: str | Path, out_dir: str | Path | None = None, *,
                 fmt: str = "rgba16f", size: int | None = None) -> Path:
    """Export `run_dir` into `out_dir` (default `run_dir/export`); returns the folder."""
    t0 = time.perf_counter()
    run_dir = Path(run_dir)
    kfmt = check_format(fmt)
    if not run_dir.is_dir():
        raise BadInput("run folder not found", file=run_dir, key="RUN_DIR")
    out_dir = Path(out_dir) if out_dir is not None else default_out(run_dir)
    _check_target(out_dir)
    with atomic_folder(out_dir, marker=MARKER, writer="sgpipe export") as staging:
        info = build(run_dir, staging, kfmt, size)
        info["files"] = {q.relative_to(staging).as_posix(): file_hash(q)
                         for q in sorted(staging.rglob("*")) if q.is_file()}
        (staging / INFO_FILE).write_text(json.dumps(info, indent=2, sort_keys=True) + "\n")
    total = sum(q.stat().st_size for q in out_dir.rglob("*") if q.is_file())
    _log(f"[export] wrote {len(info['files']) + 2} files ({total / 1e6:.2f} MB) in "
         f"{time.perf_counter() - t0:.2f} s -> {out_dir}")
    return out_dir
