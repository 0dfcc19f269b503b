"""Write the export folder of a run (`sgpipe export RUN_DIR`): read the envmap, visibility and
normalmap artifacts, build the specular mips (sgpipe.export.prefilter), write KTX2, DDS, SH9
JSON, glTF and the normal-map textures into a staging folder beside the target that replaces
it only when complete (a bad input or a failure leaves nothing half-written; a previous
export stays as it was)."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import sgpipe
from sgpipe.artifacts import envmap as env_art
from sgpipe.artifacts import visibility as vis_art
from sgpipe.errors import BadInput
from sgpipe.export import dds, env_rotation, green06, gltf, ktx2, normalmaps, prefilter, sh9
from sgpipe.export import ggx_tree, tree_prefilter
from sgpipe.export import orientation as orient
from sgpipe.io.atomic import atomic_folder, file_hash

MARKER = ".sgpipe-export"           # marks a folder this command wrote (safe to replace)
KTX2_FILE, DDS_FILE = "environment.ktx2", "environment.dds"
SH9_FILE, GLTF_FILE, BIN_FILE, INFO_FILE = ("irradiance_sh9.json", "scene.gltf", "scene.bin",
                                            "export.json")
PRODUCTS = ("ktx2", "dds", "sh9", "gltf", "normalmaps")
PREFILTERS = ("tree", "pyramid")
MAX_SIZE = 2048                     # the largest --size (the tree's memory grows as size²)
GLTF_MIN_FACE = 16                  # the extension's smallest specular mip (its "say, 16x16")
ROUGHNESS_KEY = "sgpipe.roughnessMapping"
ORIENTATION_KEY = "sgpipe.cubeOrientation"
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


def check_size(size: int | None, source_res: int, from_panorama: bool = False) -> int:
    """Base face size: the envmap stage's N by default; N/2^k; or, prefiltering from the
    panorama, any power of two up to MAX_SIZE."""
    if size is None:
        return source_res
    if from_panorama:
        if size < 1 or size > MAX_SIZE or size & (size - 1):
            raise BadInput(f"face size {size} is not a power of two from 1 to {MAX_SIZE}",
                           key="--size")
        return size
    n = source_res
    while n > size and n % 2 == 0:
        n //= 2
    if n != size:
        raise BadInput(f"face size {size} is not the source's {source_res} divided by a power "
                       "of two (larger sizes need the envmap stage's panorama and "
                       "--prefilter tree)", key="--size")
    return size


def check_only(only: str | None) -> tuple[str, ...]:
    """`--only a,b`: the products to write (all by default)."""
    if only is None:
        return PRODUCTS
    names = tuple(dict.fromkeys(x.strip() for x in only.split(",") if x.strip()))
    bad = [x for x in names if x not in PRODUCTS]
    if bad or not names:
        raise BadInput(f"unknown product {', '.join(bad) or repr(only)}; a comma-separated "
                       f"list of {', '.join(PRODUCTS)}", key="--only")
    return names


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


@dataclass(frozen=True)
class ExportOptions:
    """The command's options, checked (check_format, check_only, …)."""

    fmt: ktx2.KtxFormat = ktx2.FORMATS["rgba16f"]
    size: int | None = None
    orientation: str = orient.GLTF
    prefilter: str = "tree"
    only: tuple[str, ...] = PRODUCTS
    environment: Path | None = None


def _progress(what: str):
    def report(m, count, lv):
        how = {"source": "the source map", "direct": "direct GGX quadrature",
               "pyramid": "Γ_L pyramid, 4-SG GGX fit",
               "tree": "hierarchical GGX quadrature"}[lv.method]
        n = lv.faces.shape[1]
        _log(f"[export] {what} mip {m + 1}/{count}: {n}x{n}, roughness {lv.roughness:.3f} "
             f"(α {lv.alpha:.4f}) from {how}")
    return report


def _chain_maker(run_dir: Path, arts, opt: ExportOptions):
    """(size, make(min_size, what) → levels, info for export.json, extra input files)."""
    env = run_dir / env_art.KEY
    source_res = arts.raw.shape[1] - 2 * env_art.SAMPLE_BORDER
    if opt.prefilter == "pyramid":
        from sgpipe.envmap.store import load_pyramid
        pyr = load_pyramid(env)
        size = check_size(opt.size, source_res)
        return size, lambda min_size, what: prefilter.specular_levels(
            arts, pyr, size, _progress(what), min_size=min_size), \
            {"prefilter": "pyramid"}, []
    found = tree_prefilter.panorama_input(env, opt.environment)
    if opt.environment is not None and found[0] is None:
        raise BadInput(found[1], file=opt.environment, key="--environment")
    size = check_size(opt.size, source_res, from_panorama=found[0] is not None)
    src = tree_prefilter.load_source(env, arts, size, found)
    _log(f"[export] prefiltering from {src.note}")
    info = {"prefilter": "tree", "source": src.note, "accuracy": ggx_tree.ACCURACY}
    return size, lambda min_size, what: tree_prefilter.tree_levels(
        src, size, _progress(what), min_size=min_size), info, \
        [src.path] if src.path is not None else []


def build(run_dir: Path, staging: Path, opt: ExportOptions) -> dict:
    """Read the run, write the chosen export files into `staging`; returns export.json's
    content."""
    env = run_dir / env_art.KEY
    arts = env_art.read_pyramid(env)
    if arts.raw is None:
        raise BadInput("file not found (the export's source map)",
                       file=env / env_art.RAW_LEVEL, key=env_art.KEY)
    sh = sh9.sh9_document(env)
    rot, rot_spec, rot_file = env_rotation.read_rotation(run_dir)
    light_irradiance = np.asarray(sh["irradiance"])     # the light's: the cube's frame
    to_map = orient.cube_to_map(opt.orientation)
    light_rotation = rot                                # world ← cube
    if to_map is not None:
        light_irradiance = env_rotation.rotate_sh9(light_irradiance, to_map.T)
        light_rotation = (np.eye(3) if rot is None else rot) @ to_map
    if rot is not None:
        sh = env_rotation.rotate_sh9_document(sh, rot, rot_spec)
    size, make_chain, how, extra_inputs = _chain_maker(run_dir, arts, opt)
    info: dict = {"sgpipe_version": sgpipe.__version__, "products": list(opt.only),
                  "cubemap": {**how, "face_size": size},
                  "orientation": {"name": opt.orientation, "text": orient.TEXT[opt.orientation],
                                  "cube_to_map": None if to_map is None else to_map.tolist()}}
    if "ktx2" in opt.only or "dds" in opt.only:
        levels = make_chain(1, "cubemap")
        faces = [orient.orient_faces(lv.faces, opt.orientation) for lv in levels]
        info["cubemap_levels"] = [lv.describe() for lv in levels]
        if "ktx2" in opt.only:
            meta = {"KTXwriter": f"sgpipe {sgpipe.__version__}", ROUGHNESS_KEY: ROUGHNESS_TEXT,
                    ORIENTATION_KEY: orient.TEXT[opt.orientation]}
            (staging / KTX2_FILE).write_bytes(ktx2.write_ktx2(faces, opt.fmt, meta))
            info["ktx2"] = {"file": KTX2_FILE, "vk_format": opt.fmt.name, "levels": len(levels),
                            "roughness_mapping": ROUGHNESS_TEXT}
        if "dds" in opt.only:
            (staging / DDS_FILE).write_bytes(dds.write_dds(faces))
            info["dds"] = {"file": DDS_FILE, "dxgi_format": "R16G16B16A16_FLOAT",
                           "levels": len(levels)}
    if "sh9" in opt.only:
        (staging / SH9_FILE).write_text(json.dumps(sh, indent=2) + "\n")
        info["sh9"] = {"file": SH9_FILE}
    if "gltf" in opt.only:
        info["gltf"] = _write_gltf(run_dir, staging, size, make_chain, opt.orientation,
                                   light_irradiance, light_rotation)
    if "normalmaps" in opt.only:
        info["normal_maps"] = normalmaps.export_normal_maps(run_dir / "normalmap", staging)
    inputs = _inputs(run_dir)
    for path in extra_inputs:
        inputs[str(path)] = file_hash(path)
    if rot is not None:     # only then: an unturned export stays byte-identical
        inputs[rot_file.relative_to(run_dir).as_posix()] = file_hash(rot_file)
        info["environment_rotation"] = {
            **rot_spec, "matrix": rot.tolist(), "config": rot_file.relative_to(run_dir).as_posix(),
            "carried_by": ["scene.gltf: EXT_lights_image_based rotation (quaternion of R·M)",
                           f"{SH9_FILE}: irradiance / radiance of the turned environment"],
            "cube_frame": [KTX2_FILE, DDS_FILE, "ibl/*.png",
                           "scene.gltf: irradianceCoefficients (turned by the light's rotation)"]}
    info["run_dir_inputs"] = inputs
    return info


def _write_gltf(run_dir: Path, staging: Path, size: int, make_chain, orientation: str,
                irradiance: np.ndarray, rotation: np.ndarray | None) -> dict:
    """scene.gltf + scene.bin + ibl/*.png; returns export.json's "gltf" entry."""
    from sgpipe.io.png import write_png
    objects = load_objects(run_dir / "visibility")
    transport = green06.load_transport(run_dir / "transport")
    # the extension's chain: its own roughness spacing over the mips it lists (size … 16)
    g_levels = make_chain(min(GLTF_MIN_FACE, size), "glTF IBL")
    uris = []
    for m, lv in enumerate(g_levels):
        row = []
        oriented = orient.orient_faces(lv.faces, orientation)
        for f in range(6):
            uri = f"ibl/specular_{m:02d}_{f}.png"
            (staging / "ibl").mkdir(exist_ok=True)
            write_png(staging / uri, gltf.face_image(oriented[f]), already_8bit=True)
            row.append(uri)
        uris.append(row)
    doc, blob = gltf.build_gltf(objects, irradiance=irradiance, specular_uris=uris,
                                specular_size=size, bin_uri=BIN_FILE, transport=transport,
                                rotation=rotation)
    (staging / BIN_FILE).write_bytes(blob)
    (staging / GLTF_FILE).write_text(doc.to_json(indent=1) + "\n")
    return {"file": GLTF_FILE, "objects": [o.name for o in objects],
            "green06_objects": [t.name for t in transport],
            "ibl_levels": [lv.describe() for lv in g_levels]}


def write_export(run_dir: str | Path, out_dir: str | Path | None = None, *,
                 fmt: str = "rgba16f", size: int | None = None,
                 orientation: str = orient.GLTF, prefilter: str = "tree",
                 only: str | None = None, environment: str | Path | None = None) -> Path:
    """Export `run_dir` into `out_dir` (default `run_dir/export`); returns the folder."""
    t0 = time.perf_counter()
    run_dir = Path(run_dir)
    if prefilter not in PREFILTERS:
        raise BadInput(f"unknown prefilter {prefilter!r}; one of {', '.join(PREFILTERS)}",
                       key="--prefilter")
    opt = ExportOptions(check_format(fmt), size, orient.check_orientation(orientation),
                        prefilter, check_only(only),
                        Path(environment) if environment is not None else None)
    if not run_dir.is_dir():
        raise BadInput("run folder not found", file=run_dir, key="RUN_DIR")
    out_dir = Path(out_dir) if out_dir is not None else default_out(run_dir)
    _check_target(out_dir)
    with atomic_folder(out_dir, marker=MARKER, writer="sgpipe export") as staging:
        info = build(run_dir, staging, opt)
        info["files"] = {q.relative_to(staging).as_posix(): file_hash(q)
                         for q in sorted(staging.rglob("*")) if q.is_file()}
        (staging / INFO_FILE).write_text(json.dumps(info, indent=2, sort_keys=True) + "\n")
    total = sum(q.stat().st_size for q in out_dir.rglob("*") if q.is_file())
    _log(f"[export] wrote {len(info['files']) + 2} files ({total / 1e6:.2f} MB) in "
         f"{time.perf_counter() - t0:.2f} s -> {out_dir}")
    return out_dir
