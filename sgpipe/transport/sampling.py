"""Green06 §4.1 eq 2: direct glossy transport T_{x,v}(ω_i) = f_s(ω_i, v) V_x(ω_i) (n·ω_i)
sampled at the texels of a cubemap of light directions, for the 92 global view directions.

Visibility is view-independent, so it is traced once per vertex (one Embree occlusion query per
light texel, with the visibility stage's scene and `occluded`); the BRDF × cosine is then
evaluated for every view above the vertex's horizon. Views below the horizon get T = 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from sgpipe.core.maps import cubemap_solid_angles, cubemap_texel_dirs
from sgpipe.core.sphere import to_local
from sgpipe.visibility.trace import occluded

#: light-cube face resolutions the transport stage accepts (6·res² texels)
SUPPORTED_CUBE_RESOLUTIONS = (4, 8, 16, 32, 64)


@dataclass(frozen=True)
class LightCube:
    """Texel-centre directions (M, 3) and exact solid angles (M,) of a 6×res² cubemap,
    flattened in CONVENTIONS face/row/column order."""

    res: int
    dirs: np.ndarray
    omega: np.ndarray


@lru_cache(maxsize=8)
def light_cube(res: int) -> LightCube:
    """The light cube of face resolution `res` (CONVENTIONS cubemap layout)."""
    d = cubemap_texel_dirs(res).reshape(-1, 3)
    w = cubemap_solid_angles(res).reshape(-1)
    d.setflags(write=False)
    w.setflags(write=False)
    return LightCube(int(res), d, w)


def vertex_visibility(scene, position, normal, dirs, offset: float) -> np.ndarray:
    """(M,) bool: light direction unoccluded from the vertex (False below its horizon). Rays
    start `offset` along the normal, as in the visibility stage."""
    up = dirs @ normal > 0.0
    vis = np.zeros(len(dirs), bool)
    if scene is None:
        vis[:] = up
        return vis
    o = np.asarray(position, np.float64) + offset * np.asarray(normal, np.float64)
    idx = np.flatnonzero(up)
    if len(idx):
        origins = np.broadcast_to(o.astype(np.float32), (len(idx), 3)).copy()
        vis[idx] = ~occluded(scene, origins, np.ascontiguousarray(dirs[idx], np.float32))
    return vis


def vertex_transport(brdf, normal, tangent, bitangent, views, light: LightCube,
                     visibility: np.ndarray, min_cos: float = 0.0
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(T (V, M, 3) float64, active (V,) bool): eq 2 with the specular lobe f_s for every
    view v (rows of `views`, pointing away from the surface); views with n·v <= min_cos are
    inactive and their T is zero. (A view grazing the tangent plane sees no projected area,
    while some BRDFs — Ward's 1/√(cos θ_o) — diverge there.) The diffuse part is the
    view-independent SH transfer."""
    n_views, m = len(views), len(light.dirs)
    T = np.zeros((n_views, m, 3))
    active = views @ normal > min_cos
    lit = np.flatnonzero(visibility)
    if not brdf.has_specular or not len(lit) or not active.any():
        return T, active
    i_loc = to_local(light.dirs[lit], normal, tangent, bitangent)       # (L, 3)
    o_loc = to_local(views[active], normal, tangent, bitangent)          # (A, 3)
    f = brdf.specular(o_loc[:, None, :], i_loc[None, :, :])              # (A, L, 3)
    T[np.ix_(np.flatnonzero(active), lit)] = f * np.maximum(i_loc[:, 2], 0.0)[None, :, None]
    return T, active


__all__ = ["SUPPORTED_CUBE_RESOLUTIONS", "LightCube", "light_cube", "vertex_visibility",
           "vertex_transport"]
