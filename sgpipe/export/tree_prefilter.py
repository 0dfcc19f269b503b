"""The exported specular mips by hierarchical quadrature (sgpipe.export.ggx_tree) over a cube
resampled from the envmap stage's own panorama: mip 0 is the panorama read at each texel
centre, mip m ≥ 1 the split-sum GGX prefilter for roughness m/(M − 1) at each texel centre.
Without the panorama (moved or changed since the envmap stage read it) the source is the
stage's cube (`pyramid/raw.exr` plus its point set)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.artifacts.envmap import PyramidArtifacts
from sgpipe.envmap._cube_jit import cube_texel_dirs_jit
from sgpipe.export import ggx_mapping as gm
from sgpipe.export import ggx_tree
from sgpipe.export.prefilter import SpecularLevel, box_down, level_count, source_cube
from sgpipe.io.atomic import file_hash

MAX_SOURCE = 512        # the resampled source's face size, at most (unless --size is larger)
RESAMPLE_SUB = 2        # bilinear sub-samples per source texel and axis
SOURCE_TEXELS_PER_ALPHA = 8.0   # the source's texels across the sharpest lobe's α, at least


@dataclass
class Source:
    """What the mips are prefiltered from: the panorama when found, else the stage's cube."""

    cube: np.ndarray                    # (6, S, S, 3), S a power of two
    panorama: np.ndarray | None         # (H, W, 3)
    path: Path | None                   # the panorama's file
    note: str                           # one line for the log and export.json
    _tree: ggx_tree.CubeTree | None = None

    def tree(self) -> ggx_tree.CubeTree:
        if self._tree is None:
            self._tree = ggx_tree.build_tree(self.cube)
        return self._tree


CONFIG_PREFIX = "<config>/"


def _candidates(key: str, given: Path | None) -> list[Path]:
    """Where the manifest's input may be: `given` (--environment), else the key itself, or for
    a `<config>/…` key (relative to the config's folder, which the manifest does not record)
    that path from the working folder and from each of its sub-folders."""
    if given is not None:
        return [Path(given)]
    if not key.startswith(CONFIG_PREFIX):
        return [Path(key)]
    rel = key[len(CONFIG_PREFIX):]
    cwd = Path.cwd()
    bases = [cwd] + sorted(p for p in cwd.iterdir() if p.is_dir() and not p.name.startswith("."))
    return [b / rel for b in bases]


def panorama_input(envmap_dir: Path, given: Path | None = None) -> tuple[Path | None, str]:
    """The envmap stage's panorama, found with the content the stage hashed (its manifest's
    one input), or (None, why not)."""
    man = envmap_dir / "manifest.json"
    if not man.is_file():
        return None, "no envmap/manifest.json"
    inputs = json.loads(man.read_text()).get("inputs", {})
    if len(inputs) != 1:
        return None, "envmap/manifest.json names no single input panorama"
    (key, digest), = inputs.items()
    for path in _candidates(key, given):
        if path.is_file() and file_hash(path) == digest:
            return path.resolve(), str(path.resolve())
    if given is not None:
        return None, f"{given} is not the panorama the envmap stage read ({key})"
    return None, f"{key} not found or changed; --environment PATH names it"


def source_size(size: int, sharpest_alpha: float) -> int:
    """A power of two ≥ `size` with SOURCE_TEXELS_PER_ALPHA texels across the sharpest lobe
    (texel ≈ (π/2)/S rad), at most MAX_SOURCE unless `size` is larger."""
    want = SOURCE_TEXELS_PER_ALPHA * (math.pi / 2.0) / max(sharpest_alpha, 1e-6)
    s = 1 << max(0, math.ceil(math.log2(max(want, size))))
    return max(min(s, MAX_SOURCE), size)


def load_source(envmap_dir: Path, arts: PyramidArtifacts, size: int,
                panorama: tuple[Path | None, str]) -> Source:
    """The panorama (panorama_input's answer) resampled to a cube for a chain of face size
    `size`, or the stage's cube (which then must be at least `size`)."""
    from sgpipe.envmap.maps import latlong_to_cubemap, read_environment
    path, why = panorama
    if path is not None:
        pano = read_environment(path)
        s = source_size(size, sharpest_alpha(size))
        cube = latlong_to_cubemap(pano, s, supersample=RESAMPLE_SUB)
        return Source(cube, pano, path, f"the panorama {path} resampled to {s}²")
    cube = source_cube(arts)
    n = cube.shape[1]
    return Source(cube, None, None, f"the envmap stage's {n}² cube ({why})")


def sharpest_alpha(size: int) -> float:
    """GGX α of mip 1 of a full chain of face size `size`."""
    count = level_count(size)
    return gm.alpha_of_roughness(gm.roughness_of_level(1, count)) if count > 1 else 1.0


def point_samples(pano: np.ndarray, n: int) -> np.ndarray:
    """The panorama read bilinearly at the texel centres of an n² cube → (6, n, n, 3)."""
    from sgpipe.export.brute_force import prefilter_latlong
    return prefilter_latlong(pano, cube_texel_dirs_jit(n).reshape(-1, 3), 0.0).reshape(6, n, n, 3)


def tree_levels(src: Source, size: int, progress=None, min_size: int = 1) -> list[SpecularLevel]:
    """The mips, face size `size` down to `min_size`, roughness m/(count − 1);
    `progress(m, count, level)` after each."""
    count = level_count(size) - level_count(min_size) + 1
    levels = []
    for m in range(count):
        n = max(size >> m, 1)
        rough = gm.roughness_of_level(m, count)
        alpha = gm.alpha_of_roughness(rough)
        if m == 0 or alpha == 0.0:
            faces = point_samples(src.panorama, n) if src.panorama is not None \
                else box_down(src.cube, n)
            lv = SpecularLevel(faces, rough, alpha, "source")
        else:
            vals = ggx_tree.ggx_tree(src.tree(), cube_texel_dirs_jit(n).reshape(-1, 3), alpha)
            lv = SpecularLevel(vals.reshape(6, n, n, 3), rough, alpha, "tree",
                               info={"source_face_size": int(src.cube.shape[1]),
                                     "accuracy": ggx_tree.ACCURACY})
        levels.append(lv)
        if progress is not None:
            progress(m, count, lv)
    return levels
