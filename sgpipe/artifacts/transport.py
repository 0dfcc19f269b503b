"""The transport stage's artifacts (`<out>/transport/<object>/`, Green06): the fitted Gaussians
in compact form (`gaussians.npz`), the diffuse PRT (`sh_transfer.npz`), the mesh in the order
the per-vertex arrays follow (`geometry.npz`); `report.json` beside the objects."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io import read_npz

GAUSSIANS = "gaussians.npz"
SH_TRANSFER = "sh_transfer.npz"
GEOMETRY = "geometry.npz"
REPORT = "report.json"


def object_file(obj: str, name: str) -> str:
    """Path of one of an object's files relative to `<out>/transport/`."""
    return f"{obj}/{name}"


# -- writers (the transport stage) -------------------------------------------------------------
def write_object(sink, obj: str, *, packed: dict, cube_resolution: int, gaussians: int,
                 sh, diffuse_rgb, positions, normals, faces) -> None:
    """The three files of one object. `packed` is `sgpipe.transport.compact.encode`'s output:
    stored_mask / weight_mask (X, 12) uint8 bitsets over the 92 views, dirs (R, K, 2) uint16
    octahedral, sigma_code (R, K) uint8 over sigma_range (radians, log-uniform), weights
    (A, K, 3) float16 — rows in vertex-major, view-minor order of the set bits."""
    sink.write_npz(object_file(obj, GAUSSIANS), {
        **packed, "cube_resolution": np.int32(cube_resolution),
        "gaussians": np.int32(gaussians), "vertices": np.int32(len(positions))})
    sink.write_npz(object_file(obj, SH_TRANSFER), {
        "transfer": np.asarray(sh, np.float32), "lmax": np.int32(4),
        "diffuse_rgb": np.asarray(diffuse_rgb, np.float32)})
    f = np.float32
    sink.write_npz(object_file(obj, GEOMETRY), {
        "positions": np.asarray(positions, f), "normals": np.asarray(normals, f),
        "faces": np.asarray(faces, np.int32)})


# -- readers (the renderer, tests) -------------------------------------------------------------
def read_packed_gaussians(folder: str | Path, obj: str) -> dict:
    """The compact arrays of gaussians.npz as written (`sgpipe.transport.compact.decode` turns
    them into mu, sigma, w, stored; `sgpipe.transport.compact.read_gaussians` does both)."""
    path = Path(folder) / object_file(obj, GAUSSIANS)
    if not path.is_file():
        raise BadInput("transport artifact not found (run `sgpipe precompute`)", file=path,
                       key=f"transport.{obj}")
    return read_npz(path)


def read_sh_transfer(folder: str | Path, obj: str) -> tuple[np.ndarray, np.ndarray]:
    """(transfer (X, 25) float32 in the world-frame real SH of sgpipe.core.sh, diffuse f_d
    RGB): diffuse radiance = f_d · Σ_k L_k t_k."""
    arrays = read_npz(Path(folder) / object_file(obj, SH_TRANSFER))
    return arrays["transfer"], arrays["diffuse_rgb"]


__all__ = ["GAUSSIANS", "SH_TRANSFER", "GEOMETRY", "REPORT", "object_file", "write_object",
           "read_packed_gaussians", "read_sh_transfer"]
