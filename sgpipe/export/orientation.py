"""The cubemap orientation of `sgpipe export`: the glTF ecosystem's (glTF-IBL-Sampler,
glTF-Sample-Viewer, three.js: the panorama's centre column at +X) or sgpipe's own (at +Z).

Both are the same OpenGL / Vulkan face table; they differ by a quarter turn about +Y. A cube in
the glTF orientation shows at direction e what sgpipe's map shows at M·e = (−e_z, e_y, e_x),
so it is an exact permutation of texels (texel centres go to texel centres)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from sgpipe.core.maps import cubemap_texel_dirs, dir_to_cubemap
from sgpipe.errors import BadInput

GLTF, SGPIPE = "gltf", "sgpipe"
ORIENTATIONS = (GLTF, SGPIPE)
# cube direction e → sgpipe map direction M·e (measured against the Khronos sampler's output)
GLTF_TO_MAP = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
TEXT = {GLTF: "glTF ecosystem (Khronos glTF-IBL-Sampler, glTF-Sample-Viewer, three.js): the "
              "panorama's centre column at +X; this cube shows at direction e what sgpipe's "
              "map shows at (-e_z, e_y, e_x)",
        SGPIPE: "sgpipe's map space: the panorama's centre column at +Z"}


def check_orientation(name: str) -> str:
    if name not in ORIENTATIONS:
        raise BadInput(f"unknown orientation {name!r}; one of {', '.join(ORIENTATIONS)}",
                       key="--orientation")
    return name


def cube_to_map(name: str) -> np.ndarray | None:
    """M (3, 3): the cube's direction e shows the map's M·e; None for sgpipe's own."""
    return GLTF_TO_MAP.copy() if name == GLTF else None


@lru_cache(maxsize=16)
def _gather_index(n: int) -> np.ndarray:
    """Flat texel index into an sgpipe (6, n, n) cube for every texel of the glTF-oriented
    cube: the texel whose centre is M·e (a bijection, checked)."""
    e = cubemap_texel_dirs(n).reshape(-1, 3)
    f, s, t = dir_to_cubemap(e @ GLTF_TO_MAP.T)
    j = np.clip(np.floor(s * n).astype(np.int64), 0, n - 1)
    i = np.clip(np.floor(t * n).astype(np.int64), 0, n - 1)
    idx = (f * n + i) * n + j
    if len(np.unique(idx)) != idx.size:
        raise AssertionError(f"the quarter turn is not a texel permutation at {n}²")
    return idx


def orient_faces(faces: np.ndarray, name: str) -> np.ndarray:
    """(6, n, n, C) faces in sgpipe's map space → the same cube in orientation `name`."""
    if name == SGPIPE:
        return faces
    n = faces.shape[1]
    flat = faces.reshape(6 * n * n, *faces.shape[3:])
    return flat[_gather_index(n)].reshape(faces.shape)
