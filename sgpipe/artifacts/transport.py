"""The transport stage's artifacts (`<out>/transport/<object>/`, Green06): the fitted Gaussians
in compact form (`gaussians.npz`), the diffuse PRT (`sh_transfer.npz`), the mesh in the order
the per-vertex arrays follow (`geometry.npz`); `report.json` beside the objects."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io import read_npz

GAUSSIANS = "gaussians.npz"
#: key prefix of the unshadowed Gaussians in gaussians.npz (the same compact arrays)
OPEN = "open_"
SH_TRANSFER = "sh_transfer.npz"
GEOMETRY = "geometry.npz"
#: per-vertex materials of a textured gltf_pbr object (transport.vertex_materials)
VERTEX_MATERIALS = "vertex_material.npz"
REPORT = "report.json"


def object_file(obj: str, name: str) -> str:
    """Path of one of an object's files relative to `<out>/transport/`."""
    return f"{obj}/{name}"


# -- writers (the transport stage) -------------------------------------------------------------
def write_object(sink, obj: str, *, packed: dict, cube_resolution: int, gaussians: int,
                 sh, diffuse_rgb, positions, normals, faces, sh_indirect=None) -> None:
    """The three files of one object. `packed` is `sgpipe.transport.compact.encode`'s output:
    stored_mask / weight_mask (X, 12) uint8 bitsets over the 92 views, dirs (R, K, 2) uint16
    octahedral, sigma_code (R, K) uint8 over sigma_range (radians, log-uniform), weights
    (A, K, 3) float16 — rows in vertex-major, view-minor order of the set bits. `sh` (X, 25)
    is the shadowed transfer, `sh_indirect` (X, 25, 3) the interreflected part (RGB: the
    bounces take the colours of the surfaces met; None: zero, as without transport.indirect).
    With transport.sampling: lobe, `packed` also holds the unshadowed Gaussians' arrays under
    the same names prefixed OPEN, with zero weights (nothing stored) at the vertices whose
    unshadowed set equals the shadowed one, which `OPEN + "same"` (X,) uint8 marks."""
    sh = np.asarray(sh, np.float32)
    ind = (np.zeros(sh.shape + (3,), np.float32) if sh_indirect is None
           else np.asarray(sh_indirect, np.float32))
    sink.write_npz(object_file(obj, GAUSSIANS), {
        **packed, "cube_resolution": np.int32(cube_resolution),
        "gaussians": np.int32(gaussians), "vertices": np.int32(len(positions))})
    sink.write_npz(object_file(obj, SH_TRANSFER), {
        "transfer": sh, "transfer_indirect": ind, "lmax": np.int32(4),
        "diffuse_rgb": np.asarray(diffuse_rgb, np.float32)})
    f = np.float32
    sink.write_npz(object_file(obj, GEOMETRY), {
        "positions": np.asarray(positions, f), "normals": np.asarray(normals, f),
        "faces": np.asarray(faces, np.int32)})


def write_vertex_materials(sink, obj: str, *, kd, f0, roughness) -> None:
    """The per-vertex material each vertex's Gaussians were fitted with (rows in geometry.npz's
    vertex order): kd (X, 3), Schlick F0 (X, 3), roughness (X,), float32."""
    f = np.float32
    sink.write_npz(object_file(obj, VERTEX_MATERIALS), {
        "kd": np.asarray(kd, f), "f0": np.asarray(f0, f), "roughness": np.asarray(roughness, f)})


# -- readers (the renderer, tests) -------------------------------------------------------------
#: Green06's icosahedral view set (sgpipe.transport.views): the masks' bit count
N_VIEWS = 92


def read_packed_gaussians(folder: str | Path, obj: str) -> dict:
    """The compact arrays of gaussians.npz as written (`decode_gaussians` expands them)."""
    path = Path(folder) / object_file(obj, GAUSSIANS)
    if not path.is_file():
        raise BadInput("transport artifact not found (run `sgpipe precompute`)", file=path,
                       key=f"transport.{obj}")
    return read_npz(path)


def oct_decode(e):
    """Octahedral uint16 (..., 2) → unit directions (..., 3) (Meyer et al. 2010)."""
    q = np.asarray(e, float) / 65535 * 2 - 1
    x, y = q[..., 0], q[..., 1]
    z = 1 - np.abs(x) - np.abs(y)
    t = np.maximum(-z, 0.0)
    x = x - np.where(x >= 0, t, -t)
    y = y - np.where(y >= 0, t, -t)
    v = np.stack([x, y, z], -1)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def sigma_decode(code, lo, hi):
    """uint8 code → σ, uniform in ln σ over [lo, hi]."""
    return np.exp(np.log(lo) + np.asarray(code, float) / 255 * (np.log(hi) - np.log(lo)))


def unpack_views(bits):
    """Little-endian 92-bit masks (..., 12) uint8 → (..., 92) bool."""
    return np.unpackbits(bits, axis=-1, count=N_VIEWS, bitorder="little").astype(bool)


def decode_gaussians(arrays: dict):
    """Full arrays (mu (X, 92, K, 3), sigma (X, 92, K) radians, w (X, 92, K, 3), stored (X, 92)
    bool) of gaussians.npz's compact arrays (docs/GREEN06.md, Storage); views not stored get
    μ = 0, σ = 0 and w = 0 (the renderer never reaches them with a nonzero weight)."""
    stored, weighted = unpack_views(arrays["stored_mask"]), unpack_views(arrays["weight_mask"])
    K = arrays["dirs"].shape[1]
    X = stored.shape[0]
    lo, hi = arrays["sigma_range"]
    mu = np.zeros((X, N_VIEWS, K, 3))
    sigma = np.zeros((X, N_VIEWS, K))
    w = np.zeros((X, N_VIEWS, K, 3))
    mu[stored] = oct_decode(arrays["dirs"])
    sigma[stored] = sigma_decode(arrays["sigma_code"], lo, hi)
    scale = np.repeat(arrays["weight_scale"].astype(np.float64), weighted.sum(1))
    w[weighted] = arrays["weights"].astype(np.float64) * scale[:, None, None]
    return mu, sigma, w, stored


def decode_open_gaussians(arrays: dict, shadowed=None):
    """The unshadowed set of gaussians.npz's compact arrays (the `open_` arrays, written with
    transport.sampling: lobe) as `decode_gaussians` gives it, the shadowed set's rows at the
    vertices `open_same` marks; None where the file has none. `shadowed`: the file's
    `decode_gaussians` when the caller has it already."""
    if f"{OPEN}stored_mask" not in arrays:
        return None
    out = decode_gaussians({k[len(OPEN):]: v for k, v in arrays.items()
                            if k.startswith(OPEN) and k != f"{OPEN}same"})
    same = np.asarray(arrays[f"{OPEN}same"], bool)
    if same.any():
        for a, b in zip(out, shadowed or decode_gaussians(arrays)):
            a[same] = b[same]
    return out


def read_gaussians(folder: str | Path, obj: str, *, open_set: bool = False):
    """`decode_gaussians` of one object's gaussians.npz; `open_set`: its
    `decode_open_gaussians` instead."""
    arrays = read_packed_gaussians(folder, obj)
    return decode_open_gaussians(arrays) if open_set else decode_gaussians(arrays)


def read_vertex_materials(folder: str | Path, obj: str) -> dict | None:
    """{kd, f0, roughness} of vertex_material.npz, or None where the object's Gaussians were
    fitted with its material's factors (no file)."""
    path = Path(folder) / object_file(obj, VERTEX_MATERIALS)
    return read_npz(path) if path.is_file() else None


def read_sh_transfer(folder: str | Path, obj: str) -> tuple[np.ndarray, np.ndarray]:
    """(shadowed transfer (X, 25) float32 in the world-frame real SH of sgpipe.core.sh,
    diffuse f_d RGB): direct diffuse radiance = f_d · Σ_k L_k t_k (no interreflection:
    `read_sh_transfer_rgb` adds it)."""
    arrays = read_npz(Path(folder) / object_file(obj, SH_TRANSFER))
    return arrays["transfer"], arrays["diffuse_rgb"]


def read_sh_transfer_parts(folder: str | Path, obj: str):
    """(full transfer (X, 25, 3) float32 = shadowed + interreflected per colour channel, the
    interreflected part alone (X, 25, 3) or None when the stage ran without
    `transport.indirect`, diffuse f_d RGB), from one read of the file."""
    path = Path(folder) / object_file(obj, SH_TRANSFER)
    arrays = read_npz(path)
    t = np.asarray(arrays["transfer"], np.float32)
    full = np.repeat(t[..., None], 3, axis=-1)
    ind = None
    if "transfer_indirect" in arrays:
        ind = arrays["transfer_indirect"]
        if ind.shape != full.shape:
            raise BadInput(f"transfer_indirect has shape {ind.shape}, expected {full.shape}",
                           file=path, key="transfer_indirect")
        full = full + ind
        ind = np.asarray(ind, np.float32)
    return full, ind, arrays["diffuse_rgb"]


def read_sh_transfer_rgb(folder: str | Path, obj: str) -> tuple[np.ndarray, np.ndarray]:
    """(full transfer (X, 25, 3) float32 = shadowed + interreflected per colour channel,
    diffuse f_d RGB): diffuse radiance_c = f_d,c · Σ_k L_k,c t_k,c. Files written before the
    interreflected part existed (no `transfer_indirect`) read as shadowed only."""
    full, _, fd = read_sh_transfer_parts(folder, obj)
    return full, fd


__all__ = ["GAUSSIANS", "OPEN", "SH_TRANSFER", "GEOMETRY", "VERTEX_MATERIALS", "REPORT",
           "object_file", "write_object", "write_vertex_materials", "read_vertex_materials",
           "read_packed_gaussians", "read_sh_transfer", "read_sh_transfer_rgb",
           "read_sh_transfer_parts", "N_VIEWS",
           "oct_decode", "sigma_decode", "unpack_views", "decode_gaussians",
           "decode_open_gaussians", "read_gaussians"]
