"""Surface pixels: those whose 3×3 neighbourhood shows one object (no silhouette, no background).

A pixel is a surface pixel when it and its 8 neighbours (clipped at the image border) all
carry the same G-buffer `object_id` ≥ 0 (sgpipe.artifacts.render.GBUFFER_ARRAYS: −1 = miss).
Silhouette pixels are where one camera ray per pixel aliases against any other renderer, so
metrics "on surfaces" measure shading alone.
"""

from __future__ import annotations

import numpy as np


def surface_mask(object_id: np.ndarray) -> np.ndarray:
    """(H, W) int object ids -> (H, W) bool: 3×3 neighbourhood is one object, not a miss."""
    ids = np.asarray(object_id)
    if ids.ndim != 2:
        raise ValueError(f"object_id must be (H, W), got shape {ids.shape}")
    p = np.pad(ids, 1, mode="edge")
    h, w = ids.shape
    same = ids >= 0
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            same &= p[dy:dy + h, dx:dx + w] == ids
    return same
