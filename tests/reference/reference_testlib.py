"""Helpers for the Monte Carlo reference tests."""

from __future__ import annotations

import numpy as np


def assert_estimators_agree(res, zmax=4.5):
    """Pairwise pooled z-scores over all hit pixels and over each image quadrant (a bias
    confined to part of the sphere shows there). Per-pixel z-scores are not used: BRDF-only and
    env-only estimates are heavy-tailed, so their per-pixel stderr is itself unreliable."""
    hit = res["mis"].hit
    h, w = hit.shape
    rows, cols = np.indices(hit.shape)
    groups = [hit] + [hit & ((rows < h // 2) == top) & ((cols < w // 2) == left)
                      for top in (True, False) for left in (True, False)]
    for a, b in (("mis", "brdf"), ("mis", "env"), ("brdf", "env")):
        for g in groups:
            d = (res[a].image[g] - res[b].image[g]).astype(np.float64)
            se2 = (res[a].stderr[g].astype(np.float64) ** 2
                   + res[b].stderr[g].astype(np.float64) ** 2)
            z = d.sum(0) / np.sqrt(se2.sum(0))
            assert np.all(np.abs(z) < zmax), (a, b, g.sum(), z)
