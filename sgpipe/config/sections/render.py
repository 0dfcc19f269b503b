"""`render:` — camera, lights, methods (owned by the render stage)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sgpipe.config.schema import doc


@dataclass
class CameraSpec:
    """Pinhole camera (GUIDE: eye/target/up/fov_deg/width/height; pixel (0,0) top-left)."""

    eye: tuple[float, float, float] = doc("Camera position.", (0.0, 1.0, 4.0))
    target: tuple[float, float, float] = doc("Point looked at.", (0.0, 0.5, 0.0))
    up: tuple[float, float, float] = doc("Up vector.", (0.0, 1.0, 0.0))
    fov_deg: float = doc("Vertical field of view (degrees).", 40.0, gt=0, lt=180)
    width: int = doc("Image width (pixels).", 256, ge=1)
    height: int = doc("Image height (pixels).", 256, ge=1)


@dataclass
class RenderSection:
    """What to render."""

    camera: CameraSpec = doc("Camera.", default_factory=CameraSpec)
    methods: list[Literal["sg", "gmm", "fis", "reference"]] = doc(
        "Rendering methods to run.", default_factory=lambda: ["sg"])
