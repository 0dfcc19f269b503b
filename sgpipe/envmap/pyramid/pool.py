"""Memory of a Γ_L pyramid build: work buffers reused from level to level, and every level's
output images carved from one block.

Fresh pages cost a page fault each to map in, and a 512² build's accumulators, row sums, chain
sources and lines add up to several hundred MB, so the build reuses its buffers and allocates
its outputs in one large (huge-page advised) numpy block.
"""
from __future__ import annotations

import math

import numpy as np


class BufferPool:
    """Work buffers of one build, kept and reused from level to level (grown when a level needs
    more). A caller takes a slot only while the previous taker of the same slot is done with
    it."""

    def __init__(self):
        self.bufs = {}

    def take(self, key, shape, dtype=np.float32, zero=False) -> np.ndarray:
        shape = tuple(int(x) for x in shape)
        size = math.prod(shape)
        buf = self.bufs.get(key)
        if buf is None or buf.size < size or buf.dtype != dtype:
            buf = np.empty(size, dtype)
            self.bufs[key] = buf
        out = buf[:size].reshape(shape)
        if zero:
            out.fill(0)
        return out

    def drop(self, *names) -> None:
        """Release the slots named (a key, or the first element of a tuple key)."""
        for key in list(self.bufs):
            if key in names or (isinstance(key, tuple) and key[0] in names):
                del self.bufs[key]


def level_images(res: np.ndarray, border: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per level of face resolution n: float32 (values, slopes, samples) images of shapes
    (6·w, w, 3), (6·w, w, 3) with w = n + 2·border, and (6·(n+2), n+2, 3), all views of one
    block (one huge-page advised allocation faults in a few hundred pages instead of ~10⁴)."""
    shapes = []
    for n in res:
        w = int(n) + 2 * border
        shapes.append(((6 * w, w, 3), (6 * w, w, 3), (6 * (n + 2), n + 2, 3)))
    block = np.empty(sum(math.prod(sh) for lv in shapes for sh in lv), np.float32)
    out_views, pos = [], 0
    for lv in shapes:
        views = []
        for sh in lv:
            views.append(block[pos:pos + math.prod(sh)].reshape(sh))
            pos += math.prod(sh)
        out_views.append(tuple(views))
    return out_views
