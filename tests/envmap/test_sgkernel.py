"""The chained Γ_L levels' zonal kernels and quadrature (pyramid.kernels, pyramid.chain)
against numerical quadrature and analytic integrals."""
import functools
import math

import numpy as np
import pytest
from scipy.special import eval_legendre, roots_legendre

from sgpipe.core.sg import sg_integral
from sgpipe.envmap._cube_jit import FACE_UVA
from sgpipe.envmap.pyramid import _masses_jit as _mj
from sgpipe.envmap.pyramid.chain import CHAIN_PAD, chain_source
from sgpipe.envmap.pyramid.kernels import difference_kernel, sg_legendre


@functools.lru_cache(maxsize=4)
def _nodes(n):
    return roots_legendre(n)


def _legendre_coef(kernel, l, u_max, n=800):
    """2π ∫ K(x) P_l(x) dx over x = 1 − u, u ∈ [0, u_max], for each l (Gauss–Legendre in u)."""
    g, w = _nodes(n)
    u = 0.5 * u_max * (g + 1.0)
    p = eval_legendre(np.asarray(l)[..., None], 1.0 - u)
    return 2.0 * math.pi * 0.5 * u_max * np.sum(w * kernel(u) * p, axis=-1)


@pytest.mark.parametrize("lam", [0.7, 12.0, 300.0])
def test_sg_legendre_coefficients_match_quadrature(lam):
    k, dk = sg_legendre(lam, 12)
    for l in range(13):
        ref = _legendre_coef(lambda u: np.exp(-lam * u) / sg_integral(lam, 1.0), l, 2.0)
        assert k[l] == pytest.approx(ref, rel=1e-7, abs=1e-12)
    h = 1e-5 * lam
    kp, _ = sg_legendre(lam + h, 12)
    km, _ = sg_legendre(lam - h, 12)
    np.testing.assert_allclose(dk, (kp - km) / (2 * h), rtol=1e-6, atol=1e-10)


# (λ_a, error of the composed coefficients / S_b, error of the derivative's / its largest):
# the exp-of-quartic fit is excellent for sharp kernels and degrades towards λ ≈ 16, where
# the chain stops (the levels below come from the map)
@pytest.mark.parametrize("lam_a, tol, tol_d", [(2048.0, 5e-6, 1e-4), (128.0, 5e-6, 1e-3),
                                              (22.627416997969522, 3e-4, 5e-2)])
def test_difference_kernel_composes_to_the_sharper_sg(lam_a, tol, tol_d):
    """Funk–Hecke: coefficient_l(amp·w) · k_l(λ_a) = S_b k_l(λ_b), and the derivative kernel
    gives ∂(S_b k_l(λ_b))/∂λ_b, for every l that matters (k_l(λ_b) > 1e-4)."""
    lam_b = lam_a / math.sqrt(2.0)
    kern, amp, err = difference_kernel(lam_a, lam_b, 6.0)
    scale, zcut, k1, k2, k3, k4, g0, g1, g2, g3 = kern
    u_max = zcut / scale

    def w(u):
        z = scale * u
        return amp * np.exp(z * (k1 + z * (k2 + z * (k3 + z * k4))))

    def wd(u):
        z = scale * u
        return w(u) * (g0 + z * (g1 + z * (g2 + z * g3)))

    L = int(3 * math.sqrt(lam_b)) + 4
    ka, _ = sg_legendre(lam_a, L)
    kb, dkb = sg_legendre(lam_b, L)
    s_b = float(sg_integral(lam_b, 1.0))
    h = 1e-6 * lam_b
    ds_b = float(sg_integral(lam_b + h, 1.0) - sg_integral(lam_b - h, 1.0)) / (2 * h)
    keep = kb > 1e-4
    ls = np.arange(L + 1)[keep]
    got = _legendre_coef(w, ls, u_max) * ka[keep]
    gotd = _legendre_coef(wd, ls, u_max) * ka[keep]
    ref = s_b * kb[keep]
    refd = ds_b * kb[keep] + s_b * dkb[keep]
    np.testing.assert_allclose(got, ref, rtol=0, atol=tol * s_b)
    np.testing.assert_allclose(gotd, refd, rtol=0, atol=tol_d * np.abs(refd).max())


def _face0(s, t):
    v = s * FACE_UVA[0, 0] + t * FACE_UVA[0, 1] + FACE_UVA[0, 2]
    return v / np.linalg.norm(v)


def _extended_acc(n, ext, fn):
    """An accumulator (6, m, m, 6) holding fn(direction) at every texel centre of a cubemap of
    resolution n with border `ext` (directions beyond the face on its extended plane)."""
    m = n + 2 * ext
    c = (np.arange(m) - ext + 0.5) * 2.0 / n - 1.0
    s, t = np.meshgrid(c, c)
    acc = np.zeros((6, m, m, 6))
    for f in range(6):
        v = s[..., None] * FACE_UVA[f, 0] + t[..., None] * FACE_UVA[f, 1] + FACE_UVA[f, 2]
        v /= np.linalg.norm(v, axis=-1, keepdims=True)
        acc[f, :, :, 0:3] = fn(v)
    return acc


@pytest.mark.parametrize("n, step", [(24, 1), (64, 1), (48, 2), (128, 2)])
def test_chain_quadrature_integrates_smooth_functions(n, step):
    """The chained levels' quadrature (midpoint rule per face × a smooth partition of unity
    across the edges), on all texels or every other one: ∫ 1 = 4π, ∫ x² = 4π/3, ∫ a smooth
    bump across a cube corner, to ≤ 3e-5 relative (far closer than texel solid angles at the
    centres as weights)."""
    corner = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)

    def fn(v):
        bump = np.exp(20.0 * (v @ corner - 1.0))
        return np.stack([np.ones(v.shape[:-1]), v[..., 0] ** 2, bump], axis=-1)

    ext = 7
    acc = _extended_acc(n, ext, fn)
    src, _, h, c0 = chain_source(acc, n, ext, 1.0, step)
    total = src[:, :, _mj.E0:_mj.E2 + 1, :].astype(np.float64).sum(axis=(0, 1, 3))
    ref = np.array([4 * math.pi, 4 * math.pi / 3, 2 * math.pi * (1 - math.exp(-40.0)) / 20.0])
    np.testing.assert_allclose(total, ref, rtol=3e-5)
    m = (n + 2 * CHAIN_PAD + step - 1) // step
    assert src.shape == (6, m, _mj.NCOMP, m) and h == step * 2.0 / n
    # the row-block directions are the grid's: centres at c0 + i·h on face 0 (+X)
    np.testing.assert_allclose(src[0, m // 2, _mj.CX:_mj.CZ + 1, 0], _face0(c0, c0 + (m // 2) * h),
                               atol=1e-6)
