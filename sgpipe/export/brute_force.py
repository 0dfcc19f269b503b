"""The split-sum GGX prefilter of a lat-long panorama by brute force: every panorama texel
(its exact solid angle), sub-sampled bilinearly where the lobe is sharp — the truth the export
benchmark and tests measure sgpipe's and the Khronos sampler's mips against.

    level(r) = Σ L(ω) K_α(r·ω) Ω / Σ K_α(r·ω) Ω,   K_α(θ) = D_α(cos(θ/2)) max(cos θ, 0)

(sgpipe.export.ggx_mapping.ggx_lobe; docs/EXPORT.md). Directions are sgpipe's lat-long
convention (docs/CONVENTIONS.md); the panorama is read bilinearly (each texel a tent over its
neighbours; φ wraps, rows clamp at the poles), as both tools resample it."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from sgpipe.export.ggx_tree import ggx_kernel

SUB = 4                     # sub-samples per texel width of a tent near the lobe's peak


@njit(cache=True, inline="always")
def _bilinear(img, u, v, out):
    h, w = img.shape[0], img.shape[1]
    x = u * w - 0.5
    y = min(max(v * h - 0.5, 0.0), h - 1.0)
    j0 = int(math.floor(x))
    i0 = min(int(math.floor(y)), h - 2) if h > 1 else 0
    fx, fy = x - j0, y - i0
    j0m, j1m = j0 % w, (j0 + 1) % w
    i1 = min(i0 + 1, h - 1)
    for ch in range(3):
        a = img[i0, j0m, ch] * (1.0 - fx) + img[i0, j1m, ch] * fx
        b = img[i1, j0m, ch] * (1.0 - fx) + img[i1, j1m, ch] * fx
        out[ch] = a * (1.0 - fy) + b * fy


@njit(parallel=True, cache=True)
def _bilinear_at(img, u, v, out):
    for k in prange(len(u)):
        _bilinear(img, u[k], v[k], out[k])


@njit(parallel=True, cache=True)
def _prefilter(img, dirs, alpha, near_cos, SUB, out):
    h, w = img.shape[0], img.shape[1]
    a2 = alpha * alpha
    cos_t = np.empty(h)
    sin_t = np.empty(h)
    omega = np.empty(h)
    for i in range(h):
        th = math.pi * (i + 0.5) / h
        cos_t[i], sin_t[i] = math.cos(th), math.sin(th)
        omega[i] = (2.0 * math.pi / w) * (math.cos(math.pi * i / h) - math.cos(math.pi * (i + 1) / h))
    cos_p = np.empty(w)
    sin_p = np.empty(w)
    for j in range(w):
        ph = 2.0 * math.pi * (j + 0.5) / w
        cos_p[j], sin_p[j] = math.cos(ph), math.sin(ph)
    cell = (math.pi / h) * (2.0 * math.pi / w) / (SUB * SUB)
    for k in prange(dirs.shape[0]):
        rx, ry, rz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        acc0 = acc1 = acc2 = 0.0
        wsum = 0.0
        for i in range(h):
            st, ct = sin_t[i], cos_t[i]
            for j in range(w):
                c = rx * st * sin_p[j] + ry * ct - rz * st * cos_p[j]
                if c > near_cos:
                    # the lobe varies across the texel: integrate its bilinear tent (support
                    # ±1 texel), so each texel's light is counted once, near or far
                    kv = 0.0
                    for a in range(2 * SUB):
                        y = (a + 0.5) / SUB - 1.0
                        th = math.pi * (i + 0.5 + y) / h
                        if th <= 0.0 or th >= math.pi:
                            continue
                        s2, c2 = math.sin(th), math.cos(th)
                        for b in range(2 * SUB):
                            x = (b + 0.5) / SUB - 1.0
                            ph = 2.0 * math.pi * (j + 0.5 + x) / w
                            cs = rx * s2 * math.sin(ph) + ry * c2 - rz * s2 * math.cos(ph)
                            kv += (1.0 - abs(x)) * (1.0 - abs(y)) * s2 * cell * ggx_kernel(cs, a2)
                else:
                    kv = ggx_kernel(c, a2) * omega[i]
                if kv > 0.0:
                    acc0 += kv * img[i, j, 0]
                    acc1 += kv * img[i, j, 1]
                    acc2 += kv * img[i, j, 2]
                    wsum += kv
        out[k, 0] = acc0 / wsum
        out[k, 1] = acc1 / wsum
        out[k, 2] = acc2 / wsum


def prefilter_latlong(img: np.ndarray, dirs: np.ndarray, alpha: float,
                      sub: int = SUB) -> np.ndarray:
    """The GGX-α split-sum prefilter of panorama `img` (H, W, ≥3) at unit directions (M, 3)
    → (M, 3). α = 0 reads the panorama bilinearly. Texels within 12 α of r (at least 3 and at
    most 20 texels) are sub-sampled sub × sub."""
    img = np.ascontiguousarray(np.asarray(img)[..., :3], np.float64)
    d = np.ascontiguousarray(np.asarray(dirs, np.float64).reshape(-1, 3))
    out = np.empty((len(d), 3))
    if alpha == 0.0:
        from sgpipe.core.maps import dir_to_latlong
        u, v = dir_to_latlong(d)
        _bilinear_at(img, np.ascontiguousarray(u), np.ascontiguousarray(v), out)
        return out
    texel = math.pi / img.shape[0]
    near = max(min(12.0 * alpha, 20.0 * texel), 3.0 * texel)
    _prefilter(img, d, float(alpha), math.cos(near), int(sub), out)
    return out


@dataclass
class MipTruth:
    """Brute-force values of one mip at a sample of its texels."""

    face_size: int
    alpha: float
    pick: np.ndarray            # flat texel indices into (6, n, n)
    values: np.ndarray          # (len(pick), 3)


def mip_truths(sizes: list[int], alphas: list[float], img: np.ndarray, *,
               to_map: np.ndarray | None = None, samples: int = 3000,
               seed: int = 0) -> list[MipTruth]:
    """`prefilter_latlong` of panorama `img` at up to `samples` texel centres (all when fewer)
    of each mip (face size sizes[m], GGX α alphas[m]). `to_map`: the cube shows at e what the
    panorama shows at to_map·e (sgpipe.export.orientation)."""
    from sgpipe.core.maps import cubemap_texel_dirs
    rng = np.random.default_rng(seed)
    out = []
    for n, alpha in zip(sizes, alphas):
        dirs = cubemap_texel_dirs(n).reshape(-1, 3)
        pick = np.arange(len(dirs)) if len(dirs) <= samples else np.sort(
            rng.choice(len(dirs), samples, replace=False))
        d = dirs[pick] if to_map is None else dirs[pick] @ np.asarray(to_map).T
        out.append(MipTruth(n, float(alpha), pick, prefilter_latlong(img, d, alpha)))
    return out


def errors_against(levels: list[np.ndarray], truths: list[MipTruth]) -> list[dict]:
    """Per mip: |level − truth| (mean over RGB) as a fraction of the truth's mean — median,
    p99 and max over the sampled texels."""
    out = []
    for faces, t in zip(levels, truths):
        vals = np.asarray(faces, np.float64)[..., :3].reshape(-1, 3)[t.pick]
        err = np.abs(vals - t.values).mean(1) / t.values.mean()
        out.append({"face_size": t.face_size, "alpha": t.alpha, "median": float(np.median(err)),
                    "p99": float(np.quantile(err, 0.99)), "max": float(err.max())})
    return out


def mip_errors(levels: list[np.ndarray], img: np.ndarray, alphas: list[float], *,
               to_map: np.ndarray | None = None, samples: int = 3000,
               seed: int = 0) -> list[dict]:
    """errors_against(levels, mip_truths(…)) for one chain."""
    truths = mip_truths([lv.shape[1] for lv in levels], alphas, img, to_map=to_map,
                        samples=samples, seed=seed)
    return errors_against(levels, truths)
