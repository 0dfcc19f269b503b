"""Han07 eq 22's feature vectors: the colour textures of the objects that share a normal map,
on the map's texel grid, so that the vMF EM filters colour together with the NDF (each lobe
carries the responsibility-weighted mean colour of its normals, `vmf.fit_vmf_pyramid`).

The features are the `render.material_textures` multipliers (kd.rgb, ks.rgb; 1 where a
material has no such texture): the render multiplies them by the material's kd / ks, as it
multiplies the textures' values, so objects with different factors share one pyramid. A glTF
material's normal texture (one pyramid per material) carries its base-colour and
metallic-roughness textures as the BRDF's linear parameters kd, F0 and ln roughness, factors
applied: each lobe then has its own colour, F0 and roughness (eq 22 with eq 21)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.artifacts.normalmap import FEATURE_NAMES as NAMES    # vmf.npz's order


def texture_files(cfg, material: str) -> tuple[str | None, str | None]:
    """(kd_map, ks_map) of a material in `render.material_textures` (resolved paths)."""
    for t in (cfg.render.material_textures if cfg.render is not None else []):
        if t.material == material:
            return tuple(str(Path(p).resolve()) if p else None for p in (t.kd_map, t.ks_map))
    return None, None


def resample(img: np.ndarray, n: int) -> np.ndarray:
    """An (H, W, C) texture on an n × n texel grid of the same UV square (row 0 = v = 1 in
    both): as it is when H = W = n; the box mean of its k × k blocks when H = W = k·n (what
    the texture's MIP level holds); else bilinear at the grid's texel centres with repeat
    addressing (the renderer's tex_bilinear)."""
    img = np.asarray(img, np.float64)
    h, w = img.shape[:2]
    if h == w == n:
        return img.copy()
    if h == w and h % n == 0:
        k = h // n
        return img.reshape(n, k, n, k, -1).mean(axis=(1, 3))
    c = (np.arange(n) + 0.5) / n                     # texel centres in [0, 1]
    x = c * w - 0.5
    y = c * h - 0.5                                  # rows from the top, as the map's
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[None, :, None], (y - y0)[:, None, None]
    xa, xb = x0 % w, (x0 + 1) % w
    ya, yb = y0 % h, (y0 + 1) % h
    top = img[ya][:, xa] * (1 - fx) + img[ya][:, xb] * fx
    bot = img[yb][:, xa] * (1 - fx) + img[yb][:, xb] * fx
    return top * (1 - fy) + bot * fy


def map_features(kd_map, ks_map, n: int, read) -> np.ndarray | None:
    """(n, n, 6) features of one texture pair on an n × n map (None without textures);
    `read(path, key)` → (H, W, 3) linear texels (the render stage's reader)."""
    if kd_map is None and ks_map is None:
        return None
    out = np.ones((n, n, len(NAMES)))
    for k, (path, key) in enumerate(((kd_map, "render.material_textures.kd_map"),
                                     (ks_map, "render.material_textures.ks_map"))):
        if path is not None:
            out[..., 3 * k:3 * k + 3] = resample(read(path, key), n)[..., :3]
    return out


def gltf_map_features(params: dict, base, mr, n: int) -> np.ndarray | None:
    """(n, n, 7) features of a glTF material (GLTF_FEATURE_NAMES) on an n × n map: per texel
    the BRDF's linear parameters kd, F0 and ln roughness, factors `params` applied
    (render.setup.linear_parameters), then `resample`d — a box mean is the BRDF's mean for a
    given roughness and the roughness' geometric mean. Textures under a KHR_texture_transform
    (or on grids of their own) are read at sub-samples of each map texel (`sampled_linear`).
    `base`, `mr`: the material's GltfTextures (None: no such texture); both None: None."""
    if base is None and mr is None:
        return None
    from sgpipe.render.materials import GltfFactors
    from sgpipe.render.setup import linear_parameters
    g = GltfFactors.of_params(params)
    lin = linear_parameters(g, base, mr)
    if lin is None or lin[1].matrix is not None:
        return sampled_linear(g, base, mr, n)
    (a, b), _ = lin
    return np.concatenate([resample(a[..., :3], n), resample(b[..., :3], n),
                           resample(a[..., 3:4], n)], -1)


#: sub-samples per map texel at most (per axis), and in all
MAX_SUB, MAX_SAMPLES = 8, 1 << 22


def sampled_linear(g, base, mr, n: int) -> np.ndarray:
    """`gltf_map_features` by sampling: each map texel's mean of kd, F0, ln r over S × S
    sub-samples, the textures read bilinearly through their transforms and samplers
    (GltfTexture.bilinear), S the textures' texels across a map texel (≤ MAX_SUB, and
    S² n² ≤ MAX_SAMPLES)."""
    from dataclasses import replace

    from sgpipe.render.setup import linear_parameters
    span = 1.0
    for t in (base, mr):
        if t is not None:
            m = np.eye(3) if t.matrix is None else np.asarray(t.matrix, float)
            span = max(span, max(t.image.shape[:2]) * np.abs(m[:2, :2]).sum(1).max() / n)
    sub = int(min(np.ceil(span), MAX_SUB, max(1, np.sqrt(MAX_SAMPLES) // n)))
    c = (np.arange(n * sub) + 0.5) / (n * sub)
    u, v = np.meshgrid(c, 1.0 - c)                   # rows from the top (v = 1), as the map's
    uv = np.stack([u.ravel(), v.ravel()], -1)
    read = [None if t is None else replace(t, image=t.bilinear(uv).reshape(n * sub, n * sub,
                                                                           -1), matrix=None)
            for t in (base, mr)]
    (a, b), _ = linear_parameters(g, *read)
    both = np.concatenate([a[..., :3], b[..., :3], a[..., 3:4]], -1)
    return both.reshape(n, sub, n, sub, -1).mean(axis=(1, 3))
