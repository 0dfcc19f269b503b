"""The textures the OpenCL methods read (kd / ks multipliers, normal maps, glTF base-colour and
metallic-roughness textures), packed in one float4 buffer with their MIP chains, wrap modes and
KHR_texture_transform matrices (read by shading.h `tex_filtered` / `tex_bilinear`).

    tex = Textures()
    k = tex.add(image, mip=True, wrap=(REPEAT, CLAMP), matrix=None)   # index for the records
    texels, info, affine = tex.pack()

Layout: per texture an int4 (first texel, width, height, levels | wrap_s << 8 | wrap_t << 10)
with levels ≥ 1 (level l is max(1, w >> l) × max(1, h >> l), stored after level l − 1, rows
top to bottom), and two float4 of the glTF texture transform (row 0, row 1 of the 3×3 matrix
acting on glTF's (s, t) = (u, 1 − v); w of row 0 = 1 when present). A MIP level is the exact
box average of the level above (area-weighted where a side is odd).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sgpipe.io.gltf_textures import CLAMP, MIRROR, REPEAT

#: wrap codes of the kernels (shading.h tex_wrap)
WRAP_CODES = {REPEAT: 0, CLAMP: 1, MIRROR: 2}


def _box_halve_axis(a: np.ndarray, axis: int) -> np.ndarray:
    """Exact box average to max(1, n // 2) cells along `axis`: the integral of the
    piecewise-constant image over each output cell (cumulative sums read at the cell edges)."""
    n = a.shape[axis]
    m = max(1, n // 2)
    if n == 2 * m:
        a0 = np.take(a, np.arange(0, n, 2), axis=axis)
        a1 = np.take(a, np.arange(1, n, 2), axis=axis)
        return 0.5 * (a0 + a1)
    c = np.cumsum(np.moveaxis(a, axis, 0), axis=0, dtype=np.float64)
    c = np.concatenate([np.zeros((1,) + c.shape[1:]), c], 0)
    edges = np.arange(m + 1) * (n / m)
    i0 = np.minimum(np.floor(edges).astype(int), n - 1)
    f = (edges - i0).reshape((-1,) + (1,) * (c.ndim - 1))
    at = c[i0] + f * (c[i0 + 1] - c[i0])          # the cumulative integral at each edge
    return np.moveaxis((at[1:] - at[:-1]) * (m / n), 0, axis)


def mip_chain(img: np.ndarray) -> list[np.ndarray]:
    """Levels 0 … down to 1×1 of an (H, W, C) image, each the box average of the one above."""
    levels = [np.asarray(img, np.float64)]
    while levels[-1].shape[0] > 1 or levels[-1].shape[1] > 1:
        a = levels[-1]
        if a.shape[0] > 1:
            a = _box_halve_axis(a, 0)
        if a.shape[1] > 1:
            a = _box_halve_axis(a, 1)
        levels.append(a)
    return levels


@dataclass
class _Entry:
    image: np.ndarray
    mip: bool
    wrap: tuple[int, int]
    matrix: np.ndarray | None


@dataclass
class Textures:
    """RGBA float textures packed in one buffer; index = order of `add`."""

    entries: list = field(default_factory=list)

    def add(self, img: np.ndarray, *, mip: bool = False, wrap=(REPEAT, REPEAT),
            matrix=None) -> int:
        """A texture (H, W[, C]); `mip`: with its MIP chain (footprint-filtered lookups);
        `wrap`: glTF wrap modes (s, t); `matrix`: KHR_texture_transform's 3×3 matrix."""
        for mode in wrap:
            if mode not in WRAP_CODES:
                raise ValueError(f"unknown wrap mode {mode}")
        self.entries.append(_Entry(np.asarray(img, np.float32), bool(mip), tuple(wrap),
                                   None if matrix is None else np.asarray(matrix, float)))
        return len(self.entries) - 1

    @property
    def images(self) -> list:
        return [e.image for e in self.entries]

    def pack(self):
        """(texels (T, 4) float32, info (N, 4) int32, affine (N, 2, 4) float32)."""
        infos, parts, aff, off = [], [], [], 0
        for e in self.entries:
            im = e.image if e.image.ndim == 3 else e.image[..., None]
            h, w, c = im.shape
            rgba = np.ones((h, w, 4), np.float32)
            rgba[..., :min(c, 4)] = im[..., :4]
            if c == 1:
                rgba[..., 1:3] = im[..., :1]
            levels = mip_chain(rgba) if e.mip else [rgba]
            parts += [lv.astype(np.float32).reshape(-1, 4) for lv in levels]
            code = len(levels) | WRAP_CODES[e.wrap[0]] << 8 | WRAP_CODES[e.wrap[1]] << 10
            infos.append((off, w, h, code))
            off += sum(lv.shape[0] * lv.shape[1] for lv in levels)
            a = np.zeros((2, 4), np.float32)
            if e.matrix is not None:
                a[0, :3], a[1, :3], a[0, 3] = e.matrix[0], e.matrix[1], 1.0
            aff.append(a)
        texels = np.concatenate(parts) if parts else np.zeros((1, 4), np.float32)
        return (texels, np.asarray(infos or [(0, 1, 1, 1)], np.int32),
                np.asarray(aff, np.float32).reshape(-1, 2, 4) if aff
                else np.zeros((1, 2, 4), np.float32))
