"""The render stage's artifacts (`<out>/render/`, docs/ARTIFACTS.md render/): one linear RGB
image per method (`<method>.exr` + preview, read back by comparisons and the experiments) and
the shared primary visibility (`gbuffer.npz`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.artifacts._common import cast
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz

GBUFFER = "gbuffer.npz"
f32, i32 = np.float32, np.int32
#: gbuffer.npz arrays: (H, W[, C]); object_id / triangle_id −1 on a miss (triangle: also spheres)
GBUFFER_ARRAYS = {"hit": np.bool_, "position": f32, "normal": f32, "tangent": f32, "uv": f32,
                  "object_id": i32, "triangle_id": i32, "barycentrics": f32}


def image_name(method: str, kind: str = "exr") -> str:
    """`<method>.exr` (linear RGB), `<method>.png` (preview), `<method>.diff.png` (kind
    "diff.png": false-colour difference to `render.compare_to`)."""
    return f"{method}.{kind}"


def write_image(sink, method: str, image: np.ndarray, *, exposure: float = 0.0,
                spp: int | None = None) -> None:
    """`<method>.exr` with `sgpipe:method` (+ `sgpipe:spp` for the Monte Carlo reference) and
    its preview at 2^exposure."""
    meta = {"method": method, **({"spp": spp} if spp is not None else {})}
    sink.write_exr(image_name(method), image, exposure=exposure, metadata=meta)


def read_image(render_dir: str | Path, method: str, *, key: str | None = None) -> np.ndarray:
    """A method's image, (H, W, 3) float32 linear RGB."""
    return read_exr(Path(render_dir) / image_name(method), channels=(3, 4),
                    key=key or f"render.methods.{method}")[..., :3]


def write_gbuffer(sink, arrays: dict) -> None:
    sink.write_npz(GBUFFER, cast(arrays, GBUFFER_ARRAYS, GBUFFER))


@dataclass
class GBuffer:
    """The stored primary visibility (Embree barycentrics: P = (1−b0−b1)V0 + b0V1 + b1V2)."""

    hit: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    uv: np.ndarray
    object_id: np.ndarray
    triangle_id: np.ndarray
    barycentrics: np.ndarray


def read_gbuffer(render_dir: str | Path) -> GBuffer:
    path = Path(render_dir) / GBUFFER
    z = read_npz(path, key="render", required=tuple(GBUFFER_ARRAYS))
    hw = np.shape(z["hit"])
    channels = {"position": 3, "normal": 3, "tangent": 3, "uv": 2, "barycentrics": 2}
    for k in GBUFFER_ARRAYS:
        want = hw + ((channels[k],) if k in channels else ())
        if len(hw) != 2 or np.shape(z[k]) != want:
            raise BadInput(f"{k} has shape {np.shape(z[k])}, expected {want} (hit {hw})",
                           file=path, key="render")
    return GBuffer(**{k: z[k] for k in GBUFFER_ARRAYS})
