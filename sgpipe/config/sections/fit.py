"""`fit:` — materials and how to fit them (owned by the fit stage)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sgpipe.config.schema import InputPath, doc


@dataclass
class MaterialSpec:
    """One material: an analytic model with parameters, or a measured MERL file."""

    name: str = doc("Material name (referenced by scene objects).")
    model: str = doc("BRDF model name (see `sgpipe fit --help`).", "lambert")
    params: dict[str, Any] = doc("Model parameters (model-specific).", default_factory=dict)
    merl_file: InputPath | None = doc("MERL .binary file (model: merl).", None)


@dataclass
class FitSection:
    """Materials to fit."""

    materials: list[MaterialSpec] = doc("Materials.", default_factory=list)
