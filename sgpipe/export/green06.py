"""Green06's per-vertex transport (the transport stage's compact Gaussians and 5th-order SH
transfer) as glTF vertex attributes and lookup tables (sgpipe.export.gltf builds the file).

Per vertex (attributes, docs/EXPORT.md): `_SH_TRANSFER0…6` (25 SH coefficients + 3 zeros),
`_G06_STORED0…2` / `_G06_WEIGHTED0…2` (the 92-bit view masks as 12 bytes), `_G06_ROW` /
`_G06_WROW` (first row of the vertex in the lobe / weight tables), `_G06_SCALE` (the weights'
scale). Tables (accessors named in the mesh's extras): the 92 view directions, per stored
(vertex, view) row and Gaussian k the octahedral mean and σ code, per weighted row the RGB
weights; with interreflection the full RGB transfer (X·25 VEC3, `transfer_rgb`). A view's
Gaussians: G(ω; μ, σ) = exp((ω·μ − 1)/σ²) (Green06 eq 4, peak 1).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.artifacts import transport as tr_art
from sgpipe.io import read_npz
from sgpipe.transport.views import N_VIEWS, view_set


@dataclass
class TransportObject:
    """One transport object's arrays as the exporter stores them."""

    name: str
    positions: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    packed: dict                # sgpipe.transport.compact.encode's arrays
    sh_transfer: np.ndarray     # (X, 25)
    diffuse_rgb: np.ndarray     # (3,)
    gaussians: int
    # (X, 25, 3) shadowed + interreflected transfer; None when the interreflected part is zero
    sh_transfer_rgb: np.ndarray | None = None


def load_transport(tr_dir: Path) -> list[TransportObject]:
    """Every object folder of `transport/` (sorted by name); none when the folder is absent."""
    if not tr_dir.is_dir():
        return []
    out = []
    for d in sorted(p for p in tr_dir.iterdir() if (p / tr_art.GAUSSIANS).is_file()):
        key = f"transport.{d.name}"
        g = read_npz(d / tr_art.GEOMETRY, key=key, required=("positions", "normals", "faces"))
        packed = read_npz(d / tr_art.GAUSSIANS, key=key, required=(
            "stored_mask", "weight_mask", "dirs", "sigma_code", "weights", "weight_scale",
            "sigma_range"))
        sh, diffuse = tr_art.read_sh_transfer(tr_dir, d.name)
        full, _ = tr_art.read_sh_transfer_rgb(tr_dir, d.name)
        # shadowed + 0 is the shadowed transfer bit for bit: any difference is interreflection
        rgb = full if np.any(full != np.asarray(sh, np.float32)[..., None]) else None
        out.append(TransportObject(d.name, np.asarray(g["positions"]), np.asarray(g["normals"]),
                                   np.asarray(g["faces"]), dict(packed), np.asarray(sh),
                                   np.asarray(diffuse), int(packed["dirs"].shape[1]), rgb))
    return out


def _first_rows(mask_bytes: np.ndarray) -> np.ndarray:
    """Exclusive prefix sum of the set bits per vertex: each vertex's first table row."""
    counts = tr_art.unpack_views(mask_bytes).sum(1)
    return np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.float32)


def vertex_attributes(t: TransportObject) -> dict[str, tuple[np.ndarray, str]]:
    """{attribute name: (array (X, c), glTF type)} of one object."""
    x = len(t.positions)
    sh = np.zeros((x, 28), np.float32)
    sh[:, :25] = t.sh_transfer
    attrs = {f"_SH_TRANSFER{j}": (sh[:, 4 * j:4 * j + 4], "VEC4") for j in range(7)}
    for key, name in (("stored_mask", "_G06_STORED"), ("weight_mask", "_G06_WEIGHTED")):
        m = np.asarray(t.packed[key], np.uint8)
        for j in range(3):
            attrs[f"{name}{j}"] = (m[:, 4 * j:4 * j + 4], "VEC4")
    attrs["_G06_ROW"] = (_first_rows(np.asarray(t.packed["stored_mask"], np.uint8))[:, None],
                         "SCALAR")
    attrs["_G06_WROW"] = (_first_rows(np.asarray(t.packed["weight_mask"], np.uint8))[:, None],
                          "SCALAR")
    attrs["_G06_SCALE"] = (np.asarray(t.packed["weight_scale"], np.float32)[:, None], "SCALAR")
    return attrs


def tables(t: TransportObject) -> dict[str, tuple[np.ndarray, str]]:
    """{table name: (array (rows, c), glTF type)}: views (92, 3), lobe mean octahedral
    uint16 (R·K, 2), σ codes uint8 (R·K, 1), RGB weights float32 (A·K, 3; the stored halves
    converted exactly); with interreflection also transfer_rgb float32 (X·25, 3): entry
    x·25 + k is coefficient k of vertex x, RGB."""
    out = {"views": (view_set()[0].astype(np.float32), "VEC3"),
            "dirs": (np.asarray(t.packed["dirs"], np.uint16).reshape(-1, 2), "VEC2"),
            "sigma_code": (np.asarray(t.packed["sigma_code"], np.uint8).reshape(-1, 1),
                           "SCALAR"),
            "weights": (np.asarray(t.packed["weights"], np.float32).reshape(-1, 3), "VEC3")}
    if t.sh_transfer_rgb is not None:   # 75 floats a vertex: too many for attributes
        out["transfer_rgb"] = (np.asarray(t.sh_transfer_rgb, np.float32).reshape(-1, 3), "VEC3")
    return out


TRANSFER_RGB_TEXT = (
    "transfer_rgb (present when the transport stage computed interreflection): the full "
    "transfer, shadowed + interreflected, per colour channel; coefficient k of vertex x (its "
    "index in this primitive's vertex order) is transfer_rgb[x*25 + k] (RGB); diffuse "
    "radiance_c = diffuse_rgb_c * sum_k L_k,c transfer_rgb[x*25 + k]_c, replacing "
    "_SH_TRANSFER (which stays the shadowed part alone)")


def extras(t: TransportObject, table_accessors: dict[str, int]) -> dict:
    lo, hi = (float(v) for v in np.asarray(t.packed["sigma_range"]).reshape(-1)[:2])
    rgb = {} if t.sh_transfer_rgb is None else {"transfer_rgb_decode": TRANSFER_RGB_TEXT}
    return {"gaussians": t.gaussians, "views": N_VIEWS, "sigma_range": [lo, hi],
            "diffuse_rgb": [float(v) for v in t.diffuse_rgb],
            **{f"{name}_accessor": i for name, i in table_accessors.items()},
            "decode": "view v of vertex x is stored if bit v%8 of byte v//8 of _G06_STORED "
                      "(bytes 0..11 over the three VEC4s) is set; its row r = _G06_ROW + the "
                      "number of stored views of x below v; Gaussian k: mu = octahedral decode "
                      "of dirs[r*K + k] (uint16, Meyer et al. 2010), sigma = exp(ln lo + "
                      "code/255 (ln hi - ln lo)) with code = sigma_code[r*K + k]; weights "
                      "likewise from _G06_WEIGHTED / _G06_WROW: w = weights[r'*K + k] * "
                      "_G06_SCALE; G(l; mu, sigma) = exp((l.mu - 1)/sigma^2) for a light "
                      "direction l; views: the 92 view directions (world frame, Green06's "
                      "global frame); diffuse radiance = diffuse_rgb * sum_k L_k "
                      "_SH_TRANSFER[k] (world-frame real SH, sgpipe.core.sh order)"} | rgb
