"""The normal map as the reference and the renderer read it: the unit *bilinear* normal field
(texel values c interpolated between texel centres at half-integers, repeat addressing, then
decoded 2c − 1, n_z ≥ 10⁻³, normalised: `reference._sampling_jit.tex_bilinear` and
`reference.surface.normal_mapped_frame`, the kernels' `tex_bilinear` + `normal_from_map`).
Han07 eq 9's texel NDF γ over this continuum is approximated by s × s sub-samples per finest
texel (midpoint rule), from which the levels ≥ 1 of every pyramid are built (docs/HAN07.md,
"The map's bilinear continuum")."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sgpipe.normalmap.pyramid import box_down, level_count
from sgpipe.normalmap.read import Z_FLOOR

#: Sub-samples per texel axis that `normalmap.bilinear_samples` accepts.
SAMPLES = (1, 2, 4)


def level_shift(s: int) -> int:
    """log2 s: how many levels of the sub-sample map's pyramid lie below the map's level 0."""
    if s not in SAMPLES:
        raise ValueError(f"bilinear sub-samples per texel axis must be one of {SAMPLES}, not {s}")
    return int(s).bit_length() - 1


def subsample_coords(n: int, s: int) -> np.ndarray:
    """Positions (n·s,) of the sub-texel centres along one axis in the bilinear read's texel
    index coordinates (texel k's centre at k): sub-sample a of texel k sits at
    k + (a + ½)/s − ½, so s = 1 gives the texel centres themselves."""
    return (np.arange(n * s, dtype=np.float64) + 0.5) / s - 0.5


def _axis_weights(n: int, s: int):
    x = subsample_coords(n, s)
    x0 = np.floor(x)
    return x0.astype(np.int64) % n, (x0.astype(np.int64) + 1) % n, x - x0


def bilinear_texels(texels: np.ndarray, s: int) -> np.ndarray:
    """The texel values (n, n, C) bilinearly interpolated at the s × s sub-texel centres of
    every texel, (n·s, n·s, C), with the reference's arithmetic (a + f(b − a) per axis) and
    repeat addressing; row r of the result lies in texel row r // s (row 0 is v = 1)."""
    t = np.asarray(texels, np.float64)
    n = t.shape[0]
    c0, c1, fx = _axis_weights(n, s)
    r0, r1, fy = _axis_weights(n, s)
    # separable: every texel row interpolated along u once, then the rows along v (the same
    # operations as the reference's a = row y0 along x, b = row y1 along x, a + fy (b − a))
    tx = t[:, c0] + fx[None, :, None] * (t[:, c1] - t[:, c0])
    a = tx[r0]
    return a + fy[:, None, None] * (tx[r1] - a)


def bilinear_normals(texels: np.ndarray, s: int) -> np.ndarray:
    """Unit normals (n·s, n·s, 3) of the bilinear normal field at the sub-texel centres, from
    the map's texel values c = (n + 1)/2 (the file's channels, `read.read_normal_texels`):
    `read.decode_normals(bilinear_texels(texels, s))`, compiled, with the same operations."""
    t = np.ascontiguousarray(np.asarray(texels)[..., :3], np.float64)
    c0, c1, fx = _axis_weights(t.shape[0], s)
    out = np.empty((len(c0), len(c0), 3))
    _bilinear_decode(t, c0, c1, fx, Z_FLOOR, out)
    return out


@njit(cache=True, parallel=True)
def _bilinear_decode(t, i0, i1, f, z_floor, out):
    """out[r, c] = decode(a + f_r (b − a)) with a, b the rows i0[r], i1[r] interpolated along u
    (t[row, i0[c]] + f_c (t[row, i1[c]] − t[row, i0[c]])) — bilinear_texels' arithmetic — and
    decode as read.decode_normals: 2v − 1, n_z ≥ z_floor, divided by its length."""
    m = out.shape[0]
    for r in prange(m):
        ra, rb, fy = i0[r], i1[r], f[r]
        v = np.empty(3)
        for c in range(m):
            ca, cb, fx = i0[c], i1[c], f[c]
            for k in range(3):
                a = t[ra, ca, k] + fx * (t[ra, cb, k] - t[ra, ca, k])
                b = t[rb, ca, k] + fx * (t[rb, cb, k] - t[rb, ca, k])
                v[k] = 2.0 * (a + fy * (b - a)) - 1.0
            v[2] = max(v[2], z_floor)
            nrm = np.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
            for k in range(3):
                out[r, c, k] = v[k] / nrm


def continuum_pyramid(level0: np.ndarray, fine: np.ndarray, s: int, levels: int | None,
                      per_sample=None, band_rows: int | None = None) -> list:
    """A linear MIP pyramid whose level 0 is `per_sample(level0)` and whose level ℓ ≥ 1 holds
    the mean of `per_sample` over the (2^ℓ s)² sub-samples of `fine` a texel covers, (side_l,
    side_l, C) float64. Built in bands of `band_rows` level-1 rows (the sub-sample level of an
    SH map does not fit in memory at 1024², s = 4; default: about 2^19 sub-samples a band);
    each band is reduced by repeated 2×2 means (`pyramid.box_down`), so the values are those of
    the full sub-sample pyramid."""
    f = per_sample if per_sample is not None else (lambda x: np.asarray(x, np.float64))
    n = level0.shape[0]
    n_lev = level_count(n, levels)
    out = [f(level0)]
    if n_lev == 1:
        return out
    k = level_shift(s)
    step = 2 * s                                  # sub-sample rows per level-1 row
    if band_rows is None:
        band_rows = max(1, (1 << 19) // (step * fine.shape[1]))
    bands = []
    for r in range(0, n // 2, band_rows):
        x = f(fine[r * step:min(n // 2, r + band_rows) * step])
        for _ in range(k + 1):
            x = _box_down(x)
        bands.append(x)
    out.append(np.concatenate(bands, axis=0))
    for _ in range(2, n_lev):
        out.append(_box_down(out[-1]))
    return out


def _box_down(x: np.ndarray) -> np.ndarray:
    """`pyramid.box_down`, compiled for (h, w, C) float64 maps (the same summation order)."""
    if x.ndim != 3 or x.dtype != np.float64:
        return box_down(x)
    from sgpipe.normalmap._sh_jit import box_down_map
    out = np.empty((x.shape[0] // 2, x.shape[1] // 2, x.shape[2]))
    box_down_map(np.ascontiguousarray(x), out)
    return out
