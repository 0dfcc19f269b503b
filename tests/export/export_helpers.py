"""Tiny run folders built in the tests themselves: an envmap/ from a procedural cubemap and a
visibility/ with one small object, written through the artifact writers (no pipeline run)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import envmap as env_art
from sgpipe.artifacts import visibility as vis_art
from sgpipe.core.maps import cubemap_texel_dirs
from sgpipe.envmap import lightfit, store
from sgpipe.envmap.pyramid import PyramidSettings, build_pyramid

SPOTS = np.array([[0.5, 0.7, -0.5], [-0.8, 0.1, 0.6], [0.1, -0.3, 0.95]])
SPOTS = SPOTS / np.linalg.norm(SPOTS, axis=1, keepdims=True)


def spot_cube(n: int) -> np.ndarray:
    """A sky gradient with three soft bright spots (σ ≈ 5°–8°, up to 60× the sky): (6, n, n, 3)."""
    d = cubemap_texel_dirs(n)
    L = (0.4 + 0.25 * d[..., 1:2]) * np.array([0.9, 1.0, 1.2])
    for k, (c, lam, amp) in enumerate(zip(SPOTS, (120.0, 60.0, 200.0), (20.0, 8.0, 30.0))):
        L = L + amp * np.exp(lam * (d @ c - 1.0))[..., None] * np.array([1.0, 0.8 + 0.1 * k, 0.6])
    return L


def write_envmap(folder: Path, cube: np.ndarray, settings: PyramidSettings | None = None,
                 sh_lmax: int = 2):
    """`folder/envmap/` as the envmap stage writes its pyramid and SH light; returns the
    built Pyramid."""
    pyr = build_pyramid(cube, settings)
    sink = FolderSink(folder / env_art.KEY)
    env_art.write_pyramid(sink, store.pyramid_artifacts(pyr))
    sh = lightfit.sh_light(cube, sh_lmax)
    env_art.write_light_sh(sink, **sh, irradiance_rel_err=np.zeros(3))
    return pyr


def write_object(folder: Path, name: str = "blob", terms: int = 6, res: int = 4,
                 uvs: bool = True):
    """`folder/visibility/<name>/`: an octahedron with random SSDF PCA data; returns arrays."""
    rng = np.random.default_rng(7)
    pos = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    faces = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5],
                      [3, 1, 5], [0, 3, 5]])
    nrm = pos.copy()
    tan = np.cross(nrm, [0.3, 1.0, 0.2])
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    uv = rng.uniform(size=(6, 2))
    sink = FolderSink(folder / "visibility")
    vis_art.write_geometry(sink, name, positions=pos + [0, 1, 0], normals=nrm, tangents=tan,
                           bitangents=np.cross(nrm, tan), faces=faces,
                           uvs=uv if uvs else np.zeros((6, 2)), has_uvs=uvs, ray_offset=1e-3)
    data = dict(mean=rng.normal(size=(res, res)), basis=rng.normal(size=(terms, res, res)),
                coeffs=rng.normal(size=(6, terms)))
    vis_art.write_ssdf_pca(sink, name, **data, explained_variance=np.ones(terms),
                           resolution=res, trace_resolution=8, max_distance=1.5)
    return dict(positions=pos + [0, 1, 0], normals=nrm, tangents=tan, faces=faces, uvs=uv,
                **data)


def run_cli(*args):
    """`python -m sgpipe ARGS` → CompletedProcess (text)."""
    return subprocess.run([sys.executable, "-m", "sgpipe", *map(str, args)],
                          capture_output=True, text=True)
