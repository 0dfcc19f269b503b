"""Procedural environment maps built in the tests themselves (no dependence on data_samples)."""
import numpy as np

from sgpipe.core.maps import cubemap_solid_angles, cubemap_texel_dirs

SUN = np.array([0.42, 0.61, -0.67]) / np.linalg.norm([0.42, 0.61, -0.67])


def sky(d):
    """Smooth sky over a darker ground with a soft horizon: (..., 3)."""
    y = d[..., 1]
    up = 0.3 + 0.9 * np.clip(y, 0, None) ** 0.5
    ground = 0.12 + 0.02 * d[..., 0]
    t = 0.5 * (1 + np.tanh(y / 0.08))
    base = t * up + (1 - t) * ground
    return np.stack([base, base * 1.05, base * 1.3], -1)


def sky_sun_cube(n, sun_radiance=2e4, sun=SUN):
    """Sky + a sun one texel wide (tiny bright source) as a (6, n, n, 3) cubemap."""
    d = cubemap_texel_dirs(n)
    cube = sky(d)
    cos = d @ sun
    hot = cos >= np.sort(cos.ravel())[-3]          # the 3 texels nearest the sun direction
    cube[hot] += sun_radiance * np.array([1.0, 0.9, 0.8])
    return cube


def boxes_cube(n):
    """Dark room with three bright rectangular 'soft boxes' (sharp edges, contrast ~400)."""
    d = cubemap_texel_dirs(n)
    cube = np.full(d.shape, 0.03) * (1 + 0.5 * d[..., 1:2])
    for c, half, rad in (((0.6, 0.6, -0.5), 0.25, (14, 11, 8)), ((-0.9, 0.2, -0.3), 0.3, (2, 3, 5)),
                         ((0.0, 0.3, 0.95), 0.15, (6, 1.5, 4.5))):
        c = np.array(c) / np.linalg.norm(c)
        inside = np.arccos(np.clip(d @ c, -1, 1)) < half
        sq = inside & (np.abs((d - c)[..., 1]) < half * 0.7)
        cube[sq] = rad
    return cube


def spot_env(n: int) -> np.ndarray:
    """Cube faces (6, n, n, 3): a vertical gradient plus six small bright sources (σ ≈ 3°)."""
    d = cubemap_texel_dirs(n)
    c = np.random.default_rng(5).normal(size=(6, 3))
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    L = 0.3 + 0.2 * d[..., 1:2] * np.ones(3)
    for k, ck in enumerate(c):
        L = L + (10.0 + 10 * k) * np.exp(400.0 * (d @ ck - 1.0))[..., None] * [1.0, 0.8, 0.6]
    return L


def brute_gamma(cube, p, lam):
    """Brute-force quadrature Γ(p, λ) = Σ_texels L Ω e^{λ(ω·p − 1)} over the cubemap texels."""
    n = cube.shape[1]
    d = cubemap_texel_dirs(n).reshape(-1, 3)
    e = (cube * cubemap_solid_angles(n)[..., None]).reshape(-1, 3)
    p = np.asarray(p, float).reshape(-1, 3)
    out = np.empty((len(p), 3))
    for a in range(0, len(p), 256):
        out[a:a + 256] = np.exp(lam * (p[a:a + 256] @ d.T - 1.0)) @ e
    return out


def probe_directions(n_random=600, seed=7, extra=()):
    """Random directions plus cube seams, face corners and the poles (±Y)."""
    rng = np.random.default_rng(seed)
    r = rng.normal(size=(n_random, 3))
    seams = []
    t = np.linspace(-1, 1, 41)
    for a, b in ((0, 1), (0, 2), (1, 2)):           # edges where two |coords| tie
        for s in (1, -1):
            v = np.zeros((41, 3))
            v[:, a] = 1.0
            v[:, b] = s
            c = 3 - a - b
            v[:, c] = t * 0.999
            seams.append(v)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    poles = np.array([[0, 1, 0], [0, -1, 0], [1e-4, 1, 2e-4], [-2e-4, -1, 1e-4]], float)
    allv = np.concatenate([r, *seams, corners, poles, *[np.atleast_2d(e) for e in extra]])
    return allv / np.linalg.norm(allv, axis=1, keepdims=True)
