"""`envmap:` — environment prefiltering (owned by the environment stage)."""

from __future__ import annotations

from dataclasses import dataclass

from sgpipe.config.schema import InputPath, doc


@dataclass
class EnvmapSection:
    """Environment map and what to precompute from it."""

    environment: InputPath = doc("Lat-long HDR environment map (EXR/HDR).")
    cube_resolution: int = doc("Face resolution of the finest cubemap level.", 128, ge=4)
