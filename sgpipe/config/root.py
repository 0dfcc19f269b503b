"""The root of a config file: global settings plus one optional section per stage."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from sgpipe.config.schema import doc
from sgpipe.config.sections.envmap import EnvmapSection
from sgpipe.config.sections.fit import FitSection
from sgpipe.config.sections.normalmap import NormalmapSection
from sgpipe.config.sections.render import RenderSection
from sgpipe.config.sections.scene import SceneSection
from sgpipe.config.sections.transport import TransportSection
from sgpipe.config.sections.visibility import VisibilitySection


@dataclass
class Config:
    """A whole pipeline config. Sections that are absent (null) are not run."""

    name: str = doc("Name of this pipeline run (used in reports and the default --out).",
                    "sgpipe")
    seed: int = doc("Seed for every random choice; same seed + config = same bytes (a 63-bit "
                    "integer: random streams take it as a signed 64-bit number).", 0, ge=0,
                    le=2 ** 63 - 1)
    workers: int = doc("Worker processes for chunked stages (0 = one per core; at most 512, "
                       "each holds its own copy of a chunk's data).", 0, ge=0, le=512)
    scheduler: str | None = doc(
        "Dask scheduler address (tcp://HOST:8786) to run chunked work on instead of local "
        "processes; overridden by $SGPIPE_SCHEDULER and --scheduler. Needs the [dask] extra. "
        "An execution setting: the artifacts are the same bytes either way.", None)
    scene: SceneSection | None = doc("Geometry shared by visibility and render.", None)
    fit: FitSection | None = doc("Materials to fit into lobe representations.", None)
    envmap: EnvmapSection | None = doc("Environment-map prefiltering and light fits.", None)
    visibility: VisibilitySection | None = doc("Per-vertex visibility, SSDF and PCA.", None)
    normalmap: NormalmapSection | None = doc("Han07 normal-map filtering (vMF / SH pyramids, "
                                             "baselines) of the scene's normal maps.", None)
    transport: TransportSection | None = doc("Green06 per-vertex, per-view transport fitted "
                                             "with Gaussians, and SH diffuse transfer.", None)
    render: RenderSection | None = doc("Images to render and compare.", None)
    source: Path | None = field(default=None, repr=False, compare=False,
                                metadata={"doc": "(internal) the config file", "internal": True})
