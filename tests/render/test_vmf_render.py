"""The Han07 normal-map kernels (kernels/include/nm_shade.h: `vmf`, `normals_mip`, `toksvig`)
against Python: the vMF lookup (sgpipe.normalmap.vmf.lookup, eq 24) and eq 20
(sgpipe.normalmap.lobes.convolved_exponent) per pixel; the unfiltered map through the
reference's Blinn–Phong and normal-mapped frame at the finest level; a constant map."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.normalmap.lobes import convolved_exponent
from sgpipe.normalmap.pyramid import mean_normal_pyramid
from sgpipe.normalmap.vmf import VMFSettings, bilinear, fit_vmf_pyramid, lookup
from sgpipe.reference.surface import mapped_view, normal_mapped_frame
from sgpipe.render.envdata import EnvData
from sgpipe.render.materials import Material, pack_materials
from sgpipe.render.normalmap_data import NormalMapData, NormalMapPyramid, attach_normalmaps
from sgpipe.render.renderer import Frame, Light, ObjectShading, Renderer

S, KD, KS = 40.0, 0.3, 0.7
SIDE = 16


def _map(seed, side=SIDE, spread=0.5):
    rng = np.random.default_rng(seed)
    n = np.concatenate([rng.normal(0, spread, (side, side, 2)), np.ones((side, side, 1))], -1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def _pyramid(normals, lobes=2, kappa_max=1e4):
    p = fit_vmf_pyramid(normals, VMFSettings(lobes=lobes, kappa_max=kappa_max))
    mean = [m.astype(np.float32) for m in mean_normal_pyramid(normals)]
    return p, NormalMapPyramid(p.alpha, p.alpha_r, mean)


def _frame(n, seed, lod_texels):
    """n pixels of a flat surface z = 0 (frame t = x, n = z), random views and UVs; UV
    derivatives giving a footprint of `lod_texels` texels per pixel (array (n,))."""
    rng = np.random.default_rng(seed)
    th, ph = np.radians(rng.uniform(0, 75, n)), rng.uniform(-np.pi, np.pi, n)
    view = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    f4 = lambda a: np.concatenate([np.asarray(a, float), np.zeros((n, 1))], 1).astype(np.float32)
    uv = rng.uniform(0, 1, (n, 2)).astype(np.float32)
    duv = np.zeros((n, 4), np.float32)
    duv[:, 0] = np.asarray(lod_texels, float) / SIDE
    duv[:, 3] = 0.5 * duv[:, 0]
    return Frame(index=np.arange(n), shape=(n,), normal=f4(np.tile([0, 0, 1.0], (n, 1))),
                 tangent=f4(np.tile([1.0, 0, 0], (n, 1))), view=f4(view),
                 position=f4(np.zeros((n, 3))), uv=uv, obj=np.zeros(n, np.int32),
                 tri=np.full(n, -1, np.int32), bary=np.zeros((n, 2), np.float32), duv=duv)


LIGHTS = [Light("directional", tuple(np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9])),
                (1.0, 0.5, 0.25)),
          Light("point", (-0.5, 0.8, 1.5), (2.0, 2.0, 2.0))]


def _renderer(pyr, lights=LIGHTS, taps=1):
    m = Material.from_brdf("bp", make_brdf("blinn_phong", {"exponent": S, "kd": KD, "ks": KS}))
    r = Renderer(env=EnvData.constant(0.0), materials=pack_materials([m]),
                 objects=[ObjectShading(0, normal_map=-1)], lights=lights)
    attach_normalmaps(r, NormalMapData.pack([pyr], [S], taps))
    return r


def _light_dirs(x):
    out = []
    for L in LIGHTS:
        if L.kind == "point":
            d = np.asarray(L.vector) - x
            d2 = d @ d
            out.append((d / math.sqrt(d2), np.asarray(L.intensity) / d2))
        else:
            out.append((np.asarray(L.vector, float), np.asarray(L.intensity, float)))
    return out


def _lift(d, n, z=0.01):
    c = d @ n
    if c >= z:
        return d
    p = d - c * n
    ln = np.linalg.norm(p)
    p = p / ln if ln > 1e-8 else np.zeros(3)
    return p * math.sqrt(1 - z * z) + z * n


def _blinn(n, o, i, e, norm):
    ci = n @ i
    if ci <= 0:
        return 0.0
    h = _lift(o, n) + i
    h /= np.linalg.norm(h)
    return norm * max(n @ h, 0.0) ** e * ci


def _mean_lookup(mean, u, v, lod):
    lod = min(max(lod, 0.0), len(mean) - 1.0)
    l0 = int(math.floor(lod))
    l1, f = min(l0 + 1, len(mean) - 1), lod - l0
    m = bilinear(mean[l0].astype(np.float64), u, v) * (1 - f)
    return m + (bilinear(mean[l1].astype(np.float64), u, v) * f if f > 0 else 0.0)


def _taps(uv, duv, taps):
    """(level, tap positions) of the footprint: isotropic (taps = 1) or up to `taps` along the
    longer UV derivative at the shorter one's level (raised until they span it)."""
    lx, ly = math.hypot(*duv[:2]) * SIDE, math.hypot(*duv[2:]) * SIDE
    major, minor = max(lx, ly), min(lx, ly)
    if taps == 1:
        return math.log2(major), [np.asarray(uv, float)]
    lod = min(max(math.log2(max(minor, major / taps)), 0.0), math.log2(SIDE))
    nt = int(min(max(math.ceil(major / 2 ** lod - 1e-3), 1), taps))
    d = np.asarray(duv[:2] if lx >= ly else duv[2:], float)
    return lod, [np.asarray(uv, float) + d * ((k + 0.5) / nt - 0.5) for k in range(nt)]


def _reference_pixel(method, pyr, mean, uv, duv, view, taps=1):
    """Python mirror of one pixel: the footprint level and taps, eq 24's averages of α, α·r
    (vmf.lookup's trilinear fetch per tap), eq 20."""
    lod, pts = _taps(uv, duv, taps)
    o = _lift(view, np.array([0, 0, 1.0]))
    o /= np.linalg.norm(o)
    mn = sum(_mean_lookup(mean, p[0], p[1], lod) for p in pts) / len(pts)
    rl = np.linalg.norm(mn)
    nbar = mn / rl
    al, mu, ka = _lobes(pyr, pts, lod)
    out = np.zeros(3)
    for i, E in _light_dirs(np.zeros(3)):
        if i[2] <= 0:
            continue
        if method == "vmf":
            # diffuse: level 0's part at its unit bilinear normals, the coarser part the mean
            l0 = _level0(mean, pts, lod)
            m1 = mn - sum(w * bilinear(mean[0].astype(np.float64), float(p[0]), float(p[1]))
                          for (w, _), p in zip(l0, pts)) if l0 else mn
            diff = max(m1 @ i, 0.0) + sum(w * max(n0 @ i, 0.0) for w, n0 in l0)
            spec = 0.0
            for a, m, k in zip(al, mu, ka):
                if a <= 0 or k <= 0:
                    continue
                sp = float(convolved_exponent(S, k))
                spec += a * _blinn(m, o, i, sp, 0.25 * (S + 2) / (S + 1) * (sp + 1) / (2 * math.pi))
            for w, n0 in _level0(mean, pts, lod):
                spec += w * _blinn(n0, o, i, S, (S + 2) / (8 * math.pi))
        else:
            e = S if method == "normals_mip" else S * rl / (rl + S * (1 - rl))
            diff = max(nbar @ i, 0.0)
            spec = _blinn(nbar, o, i, e, (e + 2) / (8 * math.pi))
        out += (KD * diff / math.pi + KS * spec) * E
    return out


def _lobes(pyr, pts, lod):
    """(α, μ, κ) of the taps' averaged α and α·r (vmf.lookup's fetch per tap); where level 0
    takes part, level 1's lobes alone, α weighted f (level 0 is shaded as bilinear normals,
    `_level0`)."""
    from sgpipe.normalmap.vmf import lobe_from_texel
    lod = min(max(lod, 0.0), len(pyr.alpha) - 1.0)
    l0 = int(math.floor(lod))
    l1, f = min(l0 + 1, len(pyr.alpha) - 1), lod - l0
    tex = [np.concatenate([pyr.alpha[lv][..., None], pyr.alpha_r[lv]], 3).astype(np.float64)
           for lv in (l0, l1)]
    k_n = pyr.lobes
    fetch = lambda t, p: bilinear(t.reshape(t.shape[0], t.shape[1], -1), float(p[0]),  # noqa
                                  float(p[1])).reshape(k_n, 4)
    if len(pts) == 1 and l0 > 0:
        return lookup(pyr, float(pts[0][0]), float(pts[0][1]), lod)
    w0 = 0.0 if l0 == 0 else 1 - f
    acc = sum(fetch(tex[0], p) * w0 + (fetch(tex[1], p) * f if f > 0 else 0.0)
              for p in pts) / len(pts)
    out = [lobe_from_texel(*acc[j]) for j in range(k_n)]
    return (np.array([o[0] for o in out]), np.array([o[1] for o in out]),
            np.array([o[2] for o in out]))


def _level0(mean, pts, lod):
    """[(weight, unit normal)] of level 0's part: per tap the bilinear normal, weight (1 − f)."""
    lod = min(max(lod, 0.0), len(mean) - 1.0)
    if lod >= 1.0:
        return []
    out = []
    for p in pts:
        n = bilinear(mean[0].astype(np.float64), float(p[0]), float(p[1]))
        out.append(((1 - lod) / len(pts), n / np.linalg.norm(n)))
    return out


@pytest.mark.parametrize("method,taps", [("vmf", 1), ("normals_mip", 1), ("toksvig", 1),
                                         ("vmf", 8), ("toksvig", 4)])
def test_kernel_matches_python_lookup_and_eq20(method, taps):
    normals = _map(1)
    pyr, packed = _pyramid(normals)
    n = 48
    fr = _frame(n, 2, 2.0 ** np.linspace(-1.0, 5.0, n))     # levels below 0 … beyond the top
    fr.duv[:, 3] = fr.duv[:, 0] * np.linspace(0.05, 2.0, n)  # anisotropic, either axis longer
    img = _renderer(packed, taps=taps).shade(method, fr)
    ref = np.array([_reference_pixel(method, pyr, packed.mean, fr.uv[k], fr.duv[k],
                                     fr.view[k, :3].astype(float), taps) for k in range(n)])
    assert ref.max() > 0.05
    np.testing.assert_allclose(img, ref, rtol=1e-4, atol=1e-6 * ref.max())


def test_finest_level_equals_the_unfiltered_map_through_the_reference_brdf():
    """One lobe of κ = 10⁶ per texel at level 0, pixels at texel centres: the reference's
    Blinn–Phong in the texel's normal-mapped frame (sgpipe.reference.surface), view lifted."""
    normals = _map(3, spread=0.3)
    pyr, packed = _pyramid(normals, lobes=1, kappa_max=1e6)
    n = 40
    fr = _frame(n, 4, np.zeros(n))
    rng = np.random.default_rng(5)
    ij = rng.integers(0, SIDE, (n, 2))
    fr.uv = np.stack([(ij[:, 1] + 0.5) / SIDE, 1 - (ij[:, 0] + 0.5) / SIDE], -1).astype(np.float32)
    img = _renderer(packed).shade("vmf", fr)
    brdf = make_brdf("blinn_phong", {"exponent": S, "kd": KD, "ks": KS})
    texel = (normals[ij[:, 0], ij[:, 1]] + 1) / 2
    one = lambda v: np.tile(v, (n, 1)).astype(float)  # noqa: E731
    t, b, nz = one([1.0, 0, 0]), one([0, 1.0, 0]), one([0, 0, 1.0])
    t2, b2, n2 = normal_mapped_frame(t, b, nz, texel)
    view = mapped_view(fr.view[:, :3].astype(float), t, b, nz, t2, b2, n2)
    loc = lambda d: np.stack([np.sum(d * t2, 1), np.sum(d * b2, 1), np.sum(d * n2, 1)], -1)  # noqa
    ref = np.zeros((n, 3))
    for i, E in _light_dirs(np.zeros(3)):
        il = loc(np.tile(i, (n, 1)))
        ok = (il[:, 2] > 0) & (i[2] > 0)
        ref[ok] += brdf.eval(loc(view)[ok], il[ok]) * E * il[ok, 2:3]
    assert ref.max() > 0.05
    np.testing.assert_allclose(img, ref, rtol=2e-3, atol=1e-5 * ref.max())


@pytest.mark.parametrize("method", ["vmf", "normals_mip", "toksvig"])
def test_constant_map_equals_the_flat_surface(method):
    """A constant map tilted by 20°: every level and method shades as that one normal (the
    no-map path, which is the plain BRDF at the G-buffer normal, rotated to the tilt)."""
    c = np.array([math.sin(math.radians(20)), 0.0, math.cos(math.radians(20))])
    normals = np.tile(c, (SIDE, SIDE, 1))
    _, packed = _pyramid(normals, lobes=2, kappa_max=1e6)
    n = 40
    fr = _frame(n, 6, 2.0 ** np.linspace(0.0, 4.5, n))
    img = _renderer(packed).shade(method, fr)
    # the same pixels on a surface whose G-buffer normal is the tilted one, no map
    flat = _frame(n, 6, np.zeros(n))
    flat.normal[:, :3] = c
    flat.tangent[:, :3] = [c[2], 0.0, -c[0]]
    r = _renderer(packed)
    attach_normalmaps(r, NormalMapData.pack([None], [S]))
    ref = r.shade(method, flat)
    ok = fr.view[:, 2] > 0.2     # the views the two frames lift identically
    assert ref[ok].max() > 0.05
    np.testing.assert_allclose(img[ok], ref[ok], rtol=2e-3, atol=1e-5 * ref.max())
