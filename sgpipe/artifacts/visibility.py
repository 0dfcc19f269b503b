"""The visibility stage's artifacts (`<out>/visibility/<object>/`, docs/ARTIFACTS.md
visibility/): the object's mesh as traced (`geometry.npz`) and its per-vertex signed spherical
distance function compressed by PCA (`ssdf_pca.npz`, Wang09 eq 23–24) with the eigen-images
as EXRs; `report.json` beside the objects."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.artifacts._common import scalar, shaped
from sgpipe.errors import BadInput
from sgpipe.io import read_npz

GEOMETRY = "geometry.npz"
SSDF_PCA = "ssdf_pca.npz"
REPORT = "report.json"


def object_file(obj: str, name: str) -> str:
    """Path of one of an object's files relative to `<out>/visibility/`."""
    return f"{obj}/{name}"


def eigen_name(term: int | None, ext: str = "exr") -> str:
    """`eigen/ssdf_mean.<ext>` (term None) or `eigen/ssdf_eigen_TT.<ext>`."""
    return f"eigen/ssdf_mean.{ext}" if term is None else f"eigen/ssdf_eigen_{term:02d}.{ext}"


def preview_name(vertex: int) -> str:
    return f"previews/vertex_{vertex:05d}.png"


def _key(obj: str) -> str:
    return f"visibility.{obj}"


# -- writers (the visibility stage) -----------------------------------------------------------
def write_geometry(sink, obj: str, *, positions, normals, tangents, bitangents, faces, uvs,
                   has_uvs: bool, ray_offset: float, handedness=None) -> None:
    """`geometry.npz`: the world-space mesh whose vertex order the SSDF coefficients follow
    (`handedness` (V,) ±1 only for a mesh that has one: a glTF TANGENT's w)."""
    f = np.float32
    extra = {} if handedness is None else {"handedness": np.asarray(handedness, f)}
    sink.write_npz(object_file(obj, GEOMETRY), {**extra,
        "positions": np.asarray(positions, f), "normals": np.asarray(normals, f),
        "tangents": np.asarray(tangents, f), "bitangents": np.asarray(bitangents, f),
        "faces": np.asarray(faces, np.int32), "uvs": np.asarray(uvs, f),
        "has_uvs": np.int32(has_uvs), "ray_offset": np.float32(ray_offset)})


def write_ssdf_pca(sink, obj: str, *, mean, basis, coeffs, explained_variance,
                   resolution: int, trace_resolution: int, max_distance: float) -> None:
    """`ssdf_pca.npz` (mean (R, R), basis (T, R, R), coeffs (V, T), float32) and the mean and
    eigen-images as single-channel EXRs (their signed previews are the stage's)."""
    f = np.float32
    mean, basis = np.asarray(mean, f), np.asarray(basis, f)
    sink.write_npz(object_file(obj, SSDF_PCA), {
        "mean": mean, "basis": basis, "coeffs": np.asarray(coeffs, f),
        "explained_variance": np.asarray(explained_variance, f),
        "resolution": np.int32(resolution), "trace_resolution": np.int32(trace_resolution),
        "max_distance": np.float32(max_distance)})
    meta = {"object": obj, "resolution": resolution, "max_distance": max_distance}
    sink.write_exr(object_file(obj, eigen_name(None)), mean, png=False, metadata=meta)
    for j in range(basis.shape[0]):
        sink.write_exr(object_file(obj, eigen_name(j)), basis[j], png=False,
                       metadata={**meta, "term": j})


# -- readers (the renderer, tests) ------------------------------------------------------------
@dataclass
class Geometry:
    """An object's traced mesh: float32 (V, 3) positions / normals, (F, 3) int32 faces;
    tangents, uvs and handedness None when the file has none."""

    positions: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    tangents: np.ndarray | None = None
    uvs: np.ndarray | None = None
    handedness: np.ndarray | None = None


def read_geometry(vis_dir: str | Path, obj: str) -> Geometry:
    path = Path(vis_dir) / object_file(obj, GEOMETRY)
    key = _key(obj)
    z = read_npz(path, key=key, required=("positions", "normals", "faces"))
    v = len(shaped(z["positions"], (-1, 3), "positions", path, key))
    shaped(z["normals"], (v, 3), "normals", path, key)
    faces = np.asarray(z["faces"])
    if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
        raise BadInput(f"faces has shape {faces.shape} {faces.dtype}, expected (F, 3) integers",
                       file=path, key=key)
    if faces.size and (faces.min() < 0 or faces.max() >= v):
        raise BadInput(f"faces index vertices outside 0..{v - 1}", file=path, key=key)
    if "tangents" in z:
        shaped(z["tangents"], (v, 3), "tangents", path, key)
    if "uvs" in z:
        shaped(z["uvs"], (v, 2), "uvs", path, key)
    if "handedness" in z:
        shaped(z["handedness"], (v,), "handedness", path, key)
    return Geometry(z["positions"], z["normals"], faces, z.get("tangents"), z.get("uvs"),
                    z.get("handedness"))


@dataclass
class SsdfPca:
    """S_v ≈ mean + Σ_j coeffs[v, j] basis[j] on the R×R concentric hemisphere grid (eq 24)."""

    mean: np.ndarray            # (R, R)
    basis: np.ndarray           # (T, R, R)
    coeffs: np.ndarray          # (V, T)
    max_distance: float


def read_ssdf_pca(vis_dir: str | Path, obj: str) -> SsdfPca:
    path = Path(vis_dir) / object_file(obj, SSDF_PCA)
    key = _key(obj)
    z = read_npz(path, key=key, required=("mean", "basis", "coeffs"))
    mean = np.asarray(z["mean"])
    if mean.ndim != 2:
        raise BadInput(f"mean has shape {mean.shape}, expected (R, R)", file=path, key=key)
    basis = np.asarray(z["basis"])
    if basis.size % max(mean.size, 1):
        raise BadInput(f"basis has shape {basis.shape}, not a stack of {mean.shape} images",
                       file=path, key=key)
    basis = basis.reshape(-1, *mean.shape)
    coeffs = np.asarray(z["coeffs"])
    if coeffs.ndim != 2 or coeffs.shape[1] != len(basis):
        raise BadInput(f"coeffs has shape {coeffs.shape}, expected (V, {len(basis)})",
                       file=path, key=key)
    return SsdfPca(mean, basis, coeffs, scalar(z.get("max_distance", np.pi / 2)))
