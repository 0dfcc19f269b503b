"""Pinhole camera (CONVENTIONS: eye/target/up/fov_deg vertical/width/height; pixel (0,0) top-left).

    cam = Camera.from_spec(cfg.render.camera)        # or Camera(eye=..., target=..., ...)
    origins, dirs = cam.rays()                        # (H, W, 3) float32 each, dirs unit length
    origins, dirs = cam.rays(offset=(0.25, 0.75))     # a sub-pixel position (supersampling)
    origins, dirs = cam.rays(jitter=rng)              # one uniform random position per pixel
    origins, dirs = cam.rays_at(px, py)               # continuous positions (column, row units)

Camera basis: forward f = normalize(target − eye), right r = normalize(f × up), true up
u = r × f. Pixel (i, j) with sub-pixel position (ox, oy) ∈ [0,1)² (0.5, 0.5 = centre) looks
along normalize(f + x·tan(fov/2)·aspect·r + y·tan(fov/2)·u), x = 2(j + ox)/W − 1,
y = 1 − 2(i + oy)/H: row 0 is the top of the image, column 0 its left edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sgpipe.errors import BadInput


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@dataclass(frozen=True)
class Camera:
    """A pinhole camera; see the module docstring for the exact pixel → ray rule."""

    eye: tuple[float, float, float] = (0.0, 1.0, 4.0)
    target: tuple[float, float, float] = (0.0, 0.5, 0.0)
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov_deg: float = 40.0
    width: int = 256
    height: int = 256

    def __post_init__(self):
        f = np.subtract(self.target, self.eye, dtype=float)
        if not np.all(np.isfinite(f)) or np.linalg.norm(f) < 1e-12:
            raise BadInput("camera eye and target coincide", key="render.camera.target")
        if np.linalg.norm(np.cross(f, np.asarray(self.up, float))) < 1e-9 * np.linalg.norm(f):
            raise BadInput("camera up is parallel to the viewing direction",
                           key="render.camera.up")
        if not (0.0 < self.fov_deg < 180.0):
            raise BadInput(f"fov_deg must be in (0, 180), got {self.fov_deg}",
                           key="render.camera.fov_deg")
        if self.width < 1 or self.height < 1:
            raise BadInput("image size must be positive", key="render.camera.width")

    @classmethod
    def from_spec(cls, spec) -> "Camera":
        """Build from a config `CameraSpec` (or anything with the same attributes / keys)."""
        get = spec.get if isinstance(spec, dict) else lambda k, d=None: getattr(spec, k, d)
        return cls(eye=tuple(float(x) for x in get("eye")),
                   target=tuple(float(x) for x in get("target")),
                   up=tuple(float(x) for x in get("up", (0.0, 1.0, 0.0))),
                   fov_deg=float(get("fov_deg")), width=int(get("width")),
                   height=int(get("height")))

    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, true_up, forward) unit vectors (float64)."""
        f = _unit(np.subtract(self.target, self.eye, dtype=float))
        r = _unit(np.cross(f, np.asarray(self.up, float)))
        u = np.cross(r, f)
        return r, u, f

    def rays(self, offset: tuple[float, float] | None = None,
             jitter: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Per-pixel rays: origins (H, W, 3) and unit directions (H, W, 3), float32.

        `offset` = (ox, oy) sub-pixel position in [0,1)² (default pixel centre); `jitter`, a
        numpy Generator, draws an independent uniform position per pixel instead.
        """
        h, w = self.height, self.width
        if jitter is not None:
            ox = jitter.random((h, w))
            oy = jitter.random((h, w))
        else:
            ox, oy = (0.5, 0.5) if offset is None else offset
        j = np.arange(w, dtype=float)[None, :]
        i = np.arange(h, dtype=float)[:, None]
        return self.rays_at(*np.broadcast_arrays(j + ox, i + oy))

    def rays_at(self, px, py) -> tuple[np.ndarray, np.ndarray]:
        """Rays through continuous image-plane positions: px = column + ox, py = row + oy
        (any equal shapes S; pixel (i, j)'s centre is (j + ½, i + ½)) → origins and unit
        directions S×3, float32 (the same bits as `rays` at the same positions)."""
        h, w = self.height, self.width
        x = 2.0 * np.asarray(px, float) / w - 1.0
        y = 1.0 - 2.0 * np.asarray(py, float) / h
        x, y = np.broadcast_arrays(x, y)
        th = math.tan(math.radians(self.fov_deg) * 0.5)
        r, u, f = self.basis()
        d = f + (x * th * w / h)[..., None] * r + (y * th)[..., None] * u
        d = _unit(d).astype(np.float32)
        o = np.broadcast_to(np.asarray(self.eye, np.float32), d.shape).copy()
        return o, d

    def project(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) → continuous pixel coordinates (..., 2) as (column, row)."""
        p = np.asarray(points, float) - np.asarray(self.eye, float)
        r, u, f = self.basis()
        z = p @ f
        th = math.tan(math.radians(self.fov_deg) * 0.5)
        x = (p @ r) / (z * th * self.width / self.height)
        y = (p @ u) / (z * th)
        return np.stack([(x + 1.0) * 0.5 * self.width, (1.0 - y) * 0.5 * self.height], -1)
