"""Read a run folder (`<out>/<stage>/manifest.json` and what it lists) into plain data for the
report page: stage manifests and timings, the render stage's images and metrics
(`report.compare`, docs/ARTIFACTS.md render/), the fit reports and plots, the envmap previews
and the visibility reports. Only files a stage's manifest lists are shown, so the page never
mixes runs; a listed file that is missing on disk is reported, not shown."""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sgpipe.errors import BadInput
from sgpipe.io import file_hash

#: stages with a section of their own, in pipeline order; any other `<stage>/manifest.json`
#: found in the folder is listed with its manifest only
KNOWN_STAGES = ("fit", "envmap", "visibility", "render")
MANIFEST, TIMINGS = "manifest.json", "timings.json"
#: which command writes each known stage (for the "absent" notes)
STAGE_COMMAND = {"fit": "fit", "envmap": "precompute", "visibility": "precompute",
                 "render": "render"}
EIGEN_SHOWN = 8     # SSDF eigen-images shown per object (beside the mean)
#: envmap previews, in the order shown: (file, caption)
ENVMAP_PREVIEWS = (
    ("preview_pyramid.png", "Γ_L pyramid levels as lat-long thumbnails, sharpest λ on the left"),
    ("preview_light_fit.png", "environment (left) beside its SG light fit (right), lat-long"),
    ("preview_irradiance.png", "irradiance: exact / SG fit / SH fit, top to bottom, one scale"),
    ("irradiance.png", "exact irradiance E(n), lat-long in the normal"),
)


@dataclass
class Picture:
    """A PNG of the run: its file, where the page finds it (relative to the page), its size."""

    source: Path
    href: str
    caption: str
    width: int
    height: int
    display: int = 0        # preferred display width (small images are enlarged to it)


@dataclass
class Stage:
    name: str
    folder: Path
    manifest: dict
    timings: dict
    missing: list[str] = field(default_factory=list)   # listed outputs not on disk
    changed: list[str] = field(default_factory=list)   # on disk, not the bytes the manifest lists

    @property
    def outputs(self) -> dict:
        return self.manifest.get("outputs") or {}

    @property
    def report(self) -> dict:
        return self.manifest.get("report") or {}


@dataclass
class MethodRow:
    """One rendered method: its image, difference image and metrics against the truth."""

    method: str
    image: Picture | None
    diff: Picture | None
    metrics: dict | None            # report.compare[method] (None for the truth itself)
    seconds: float | None           # timings.json `<method>_s`
    build_s: float | None           # `<method>_build_s`


@dataclass
class Material:
    name: str
    model: str
    params: dict
    report: dict                    # `<material>/report.json`
    pictures: list[Picture]


@dataclass
class Run:
    root: Path
    stages: dict[str, Stage]
    methods: list[MethodRow] = field(default_factory=list)
    truth: MethodRow | None = None
    render_facts: dict = field(default_factory=dict)
    materials: list[Material] = field(default_factory=list)
    envmap_previews: list[Picture] = field(default_factory=list)
    visibility_objects: dict[str, dict] = field(default_factory=dict)
    visibility_pictures: dict[str, list[Picture]] = field(default_factory=dict)

    def has(self, stage: str) -> bool:
        return stage in self.stages


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) from a PNG's IHDR chunk; a file that is no PNG is BadInput."""
    with open(path, "rb") as f:
        head = f.read(24)
    if len(head) < 24 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        raise BadInput("not a PNG file", file=path, key="report")
    return struct.unpack(">II", head[16:24])


def _json(path: Path, stage: str) -> Any:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise BadInput(f"unreadable JSON ({e})", file=path, key=stage) from None


def check_run_dir(run_dir: Path) -> None:
    """BadInput naming `run_dir` when it is missing or not a folder."""
    if not run_dir.exists():
        raise BadInput("run folder not found", file=run_dir, key="RUN_DIR")
    if not run_dir.is_dir():
        raise BadInput("not a folder (give the --out folder of `sgpipe run`)", file=run_dir,
                       key="RUN_DIR")


def find_stages(run_dir: Path) -> dict[str, Stage]:
    """Every `<stage>/manifest.json` of the folder: known stages in pipeline order, others after
    them by name. A folder without any is not a run folder (BadInput naming it)."""
    check_run_dir(run_dir)
    found = sorted(p.parent.name for p in run_dir.glob(f"*/{MANIFEST}") if p.is_file())
    if not found:
        raise BadInput("not an sgpipe run folder: no <stage>/manifest.json in it (fit, envmap, "
                       "visibility or render; give the --out folder of `sgpipe run`)",
                       file=run_dir, key="RUN_DIR")
    order = [s for s in KNOWN_STAGES if s in found] + [s for s in found if s not in KNOWN_STAGES]
    stages = {}
    for name in order:
        folder = run_dir / name
        man = _json(folder / MANIFEST, name)
        if not isinstance(man, dict) or not isinstance(man.get("outputs", {}), dict):
            raise BadInput("not a stage manifest (no 'outputs' mapping)", file=folder / MANIFEST,
                           key=name)
        tim = _json(folder / TIMINGS, name) if (folder / TIMINGS).is_file() else {}
        st = Stage(name, folder, man, tim if isinstance(tim, dict) else {})
        st.missing = sorted(f for f in st.outputs if not (folder / f).is_file())
        st.changed = sorted(f for f, digest in st.outputs.items()
                            if f not in st.missing and not _same_bytes(folder / f, digest))
        stages[name] = st
    return stages


def _same_bytes(path: Path, digest: str) -> bool:
    try:
        return file_hash(path) == digest
    except OSError:
        return False


def picture(stage: Stage, name: str, caption: str) -> Picture | None:
    """The stage's output `name` as a Picture (None when not listed, not on disk, or changed
    since the stage wrote it)."""
    if (name not in stage.outputs or not (stage.folder / name).is_file()
            or name in stage.changed):
        return None
    w, h = png_size(stage.folder / name)
    return Picture(stage.folder / name, f"assets/{stage.name}/{name}", caption, w, h)


def collect(run_dir: str | Path) -> Run:
    """Everything the page shows, read from `run_dir`."""
    run_dir = Path(run_dir)
    run = Run(run_dir, find_stages(run_dir))
    if run.has("render"):
        _render(run, run.stages["render"])
    if run.has("fit"):
        _fit(run, run.stages["fit"])
    if run.has("envmap"):
        _envmap(run, run.stages["envmap"])
    if run.has("visibility"):
        _visibility(run, run.stages["visibility"])
    return run


def _render(run: Run, st: Stage) -> None:
    params = (st.manifest.get("params") or {}).get("render") or {}
    methods = list(params.get("methods") or [])
    truth = params.get("compare_to")
    compare = st.report.get("compare") or {}
    rows = []
    for m in methods:
        rows.append(MethodRow(
            method=m, image=picture(st, f"{m}.png", f"{m}"),
            diff=picture(st, f"{m}.diff.png", f"{m}: false-colour |{m} − {truth}|"),
            metrics=compare.get(m), seconds=st.timings.get(f"{m}_s"),
            build_s=st.timings.get(f"{m}_build_s")))
    run.truth = next((r for r in rows if r.method == truth), None)
    run.methods = [r for r in rows if r.method != truth]
    cam = params.get("camera") or {}
    run.render_facts = {
        "truth": truth, "size": f"{cam.get('width')}×{cam.get('height')}" if cam else None,
        "spp": params.get("spp"), "preview_exposure": params.get("preview_exposure"),
        "reference_mean_stderr": st.report.get("reference_mean_stderr"),
        "shaded_pixels": st.report.get("shaded_pixels"),
        "reference_s": st.timings.get("reference_s"),
        "mean_rgb": st.report.get("mean_rgb") or {}}


def _fit(run: Run, st: Stage) -> None:
    index = st.folder / "materials.json"
    names = (_json(index, "fit") or {}).get("materials", []) if index.is_file() else []
    for name in names:
        rep_file = f"{name}/report.json"
        rep = _json(st.folder / rep_file, "fit") if rep_file in st.outputs and \
            (st.folder / rep_file).is_file() else {}
        pics = [p for p in (
            picture(st, f"{name}/error_vs_lobes.png", f"{name}: fit error vs lobe count"),
            picture(st, f"{name}/slices.png", f"{name}: BRDF slices vs vMF-mixture fit"))
            if p is not None]
        run.materials.append(Material(name, rep.get("model", "?"), rep.get("params") or {},
                                      rep, pics))


def _envmap(run: Run, st: Stage) -> None:
    run.envmap_previews = [p for p in (picture(st, f, c) for f, c in ENVMAP_PREVIEWS) if p]


def _visibility(run: Run, st: Stage) -> None:
    rep_path = st.folder / "report.json"
    rep = _json(rep_path, "visibility") if "report.json" in st.outputs and \
        rep_path.is_file() else {}
    run.visibility_objects = (rep or {}).get("objects") or {}
    for obj in run.visibility_objects:
        files = sorted(f for f in st.outputs if f.startswith(f"{obj}/") and f.endswith(".png"))
        # the mean and the leading eigen-images (the rest are noise-like), then the vertices
        eigen = [f for f in files if f.endswith("/eigen/ssdf_mean.png")] + \
            [f for f in files if "/eigen/ssdf_eigen_" in f][:EIGEN_SHOWN]
        pics = []
        for f, width in [(f, 96) for f in eigen] + [(f, 384) for f in files if "/previews/" in f]:
            p = picture(st, f, _visibility_caption(f))
            if p is not None:
                p.display = width
                pics.append(p)
        run.visibility_pictures[obj] = pics


def _visibility_caption(name: str) -> str:
    stem = name.rsplit("/", 1)[-1][:-4]
    if stem.startswith("vertex_"):
        return (f"vertex {int(stem[7:])}: visibility | SSDF | PCA reconstruction | "
                "1 − 4|error|/max distance")
    return stem.replace("ssdf_", "SSDF ").replace("eigen_", "eigen-image ")
