"""`visibility:` — per-vertex visibility, SSDF and PCA (owned by the visibility stage)."""

from __future__ import annotations

from dataclasses import dataclass

from sgpipe.config.schema import doc


@dataclass
class VisibilitySection:
    """Visibility precomputation for the objects of `scene:`."""

    trace_resolution: int = doc("Concentric-square trace resolution per vertex.", 512, ge=8)
    resolution: int = doc("Downsampled visibility/SSDF resolution.", 128, ge=4)
    pca_terms: int = doc("Number of PCA terms N_V.", 48, ge=1)
