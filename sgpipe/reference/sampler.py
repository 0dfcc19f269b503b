"""The environment of the `reference` method: a piecewise-constant lat-long map with its
importance-sampling distribution (texel probability ∝ luminance × solid angle, exact solid-angle
pdf; `_sampling_jit`), optionally turned by a rotation R (render.environment_rotation): the
world radiance is L(Rᵀω), samples are drawn in the map and turned by R, and a rotation keeps
solid angles, so the pdf of ω is the map's pdf at Rᵀω."""

from __future__ import annotations

import os

import numpy as np

from sgpipe.core.rotation import checked_rotation
from sgpipe.reference import _sampling_jit as jit

LUMA = np.array([0.2126, 0.7152, 0.0722])


class EnvSampler:
    """Piecewise-constant lat-long environment with its importance-sampling distribution."""

    def __init__(self, image, rotation=None):
        if image is None:
            image = np.zeros((1, 2, 3))
        if isinstance(image, (str, os.PathLike)):
            from sgpipe.io import read_exr
            image = read_exr(image, channels=(1, 3, 4), key="envmap.environment")
        rgb = np.asarray(image, np.float64)
        if rgb.ndim == 2:
            rgb = rgb[:, :, None]
        if rgb.shape[2] == 1:
            rgb = np.repeat(rgb, 3, axis=2)
        rgb = np.ascontiguousarray(rgb[:, :, :3])
        if not np.isfinite(rgb).all():
            raise ValueError("environment has NaN/Inf texels")
        self.rgb = np.maximum(rgb, 0.0)
        self.lum = np.ascontiguousarray(self.rgb @ LUMA)
        self.row_cdf, self.col_cdf, self.cos_edge, self.z = jit.build_distribution(self.lum)
        self.rotation = checked_rotation(rotation)

    def __reduce__(self):
        # pickled (to the worker processes) as the image and rotation; the tables are rebuilt
        return (EnvSampler, (self.rgb, self.rotation))

    def rotated(self, rotation) -> "EnvSampler":
        """The same map turned by `rotation` (3×3 world ← map) after its own rotation; None:
        self. The tables are shared."""
        if rotation is None:
            return self
        R = checked_rotation(rotation)
        if self.rotation is not None:
            R = R @ self.rotation
        out = object.__new__(EnvSampler)
        out.__dict__.update(self.__dict__)
        out.rotation = R
        return out

    @property
    def shape(self):
        return self.lum.shape

    def sample(self, u1, u2):
        """(world dirs (N,3), solid-angle pdf (N,), radiance (N,3)) for uniforms u1, u2 (N,)."""
        d, pdf, rad = jit.sample_env(np.ascontiguousarray(u1, np.float64),
                                     np.ascontiguousarray(u2, np.float64), self.row_cdf,
                                     self.col_cdf, self.cos_edge, self.lum, self.rgb, self.z)
        if self.rotation is not None:
            d = d @ self.rotation.T
        return d, pdf, rad

    def lookup(self, dirs):
        """(radiance (N,3), pdf (N,)) of unit world directions (N,3)."""
        d = np.asarray(dirs, np.float64)
        if self.rotation is not None:
            d = d @ self.rotation
        return jit.lookup_env(np.ascontiguousarray(d), self.lum, self.rgb, self.z)

    def pdf(self, dirs):
        return self.lookup(dirs)[1]


