"""`sgpipe compare A.exr B.exr`: image metrics against a reference (owned by the render stage)."""

from __future__ import annotations
