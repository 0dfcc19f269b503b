"""Han07 §7: EM recovers a known vMF mixture through the pyramid, the eq 20–21 closed forms vs
quadrature, the α / α·r textures and their lookup, alignment (eq 23) vs interpolation error,
determinism."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import get_num_threads, set_num_threads

from sgpipe.core.vmf import vmf_pdf
from sgpipe.normalmap.lobes import (blinn_phong_lobe, convolved_exponent, convolved_sigma,
                                    torrance_sparrow_lobe)
from sgpipe.normalmap.vmf import (VMFSettings, fit_vmf_pyramid, lookup, mixture_blinn_phong,
                                  texel_lobes)

from .quadrature import frame, polar_rule, vmf_samples_stratified

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import sample_normalmaps  # noqa: E402


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


@pytest.fixture(scope="module")
def grooves64():
    return np.ascontiguousarray(sample_normalmaps.grooves_normals(256)[:64, :64])


def test_em_recovers_a_two_lobe_mixture():
    """64² normals: 2448 stratified draws from vMF(μ_A, 40), 1648 from vMF(μ_B, 120), shuffled
    over the map; the 1×1 level's 2-lobe fit finds α, μ, κ."""
    mu_a, mu_b = _unit([0.4, 0.1, 0.9]), _unit([-0.3, -0.35, 0.88])
    a = vmf_samples_stratified(mu_a, 40.0, 48, 51)        # 2448 normals
    b = vmf_samples_stratified(mu_b, 120.0, 103, 16)      # 1648
    x = np.concatenate([a, b])
    x = x[np.random.default_rng(1).permutation(len(x))].reshape(64, 64, 3)
    pyr = fit_vmf_pyramid(x, VMFSettings(lobes=2, max_iter=200, tol=1e-10))
    al, mu, ka = texel_lobes(pyr, 6, 0, 0)
    k = np.argsort(-al)
    al, mu, ka = al[k], mu[k], ka[k]
    np.testing.assert_allclose(al, [len(a) / 4096, len(b) / 4096], atol=0.01)
    assert np.degrees(np.arccos(np.clip(mu[0] @ mu_a, -1, 1))) < 1.0
    assert np.degrees(np.arccos(np.clip(mu[1] @ mu_b, -1, 1))) < 1.0
    # Banerjee's κ is an approximation of A⁻¹ and the two lobes overlap a little: within 10 %
    np.testing.assert_allclose(ka, [40.0, 120.0], rtol=0.1)


def _convolve(f, mu, kappa, omega):
    d, w = polar_rule(n_beta=600, n_phi=512)
    n = d @ frame(mu).T
    dens = w * vmf_pdf(n, mu, kappa)
    return np.array([np.sum(dens * f(n @ o)) for o in omega])


@pytest.mark.parametrize("s,kappa,tol", [(50.0, 100.0, 0.03), (20.0, 40.0, 0.03),
                                         (200.0, 60.0, 0.04)])
def test_eq20_blinn_phong_vmf_closed_form_vs_quadrature(s, kappa, tol):
    """ρ_eff(ω) = ∫ f_s(ω·n) vMF(n; μ, κ) dn ≈ (s′+1)/(2π) (ω·μ)^{s′}, s′ = κs/(κ+s)."""
    mu = _unit([0.1, 0.2, 0.95])
    sp = float(convolved_exponent(s, kappa))
    th = np.linspace(0.0, 3.0 / math.sqrt(sp), 7)
    local = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    omega = local @ frame(mu).T
    want = _convolve(lambda u: blinn_phong_lobe(u, s), mu, kappa, omega)
    got = blinn_phong_lobe(omega @ mu, sp)
    peak = want[0]
    assert np.abs(got - want).max() / peak < tol
    # a wrong width is far off: s′ = s (no filtering) or s′ = κ + s
    for bad in (s, kappa + s):
        assert np.abs(blinn_phong_lobe(omega @ mu, bad) - want).max() / peak > 3 * tol


@pytest.mark.parametrize("sigma,kappa", [(0.1, 100.0), (0.05, 50.0), (0.2, 20.0)])
def test_eq21_torrance_sparrow_vmf_closed_form_vs_quadrature(sigma, kappa):
    """Eq 18's lobe of width σ convolved with vMF(κ) ≈ the same lobe with σ′ = √(σ² + 1/(2κ))."""
    mu = _unit([-0.2, 0.1, 0.97])
    sp = float(convolved_sigma(sigma, kappa))
    th = np.linspace(0.0, 3.0 * sp, 7)
    local = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    omega = local @ frame(mu).T
    want = _convolve(lambda u: torrance_sparrow_lobe(u, sigma), mu, kappa, omega)
    got = torrance_sparrow_lobe(omega @ mu, sp)
    assert np.abs(got - want).max() / want[0] < 0.03
    assert np.abs(torrance_sparrow_lobe(omega @ mu, sigma) - want).max() / want[0] > 0.1


def test_textures_round_trip_and_lookup(grooves64):
    pyr = fit_vmf_pyramid(grooves64, VMFSettings(lobes=4))
    assert [a.shape for a in pyr.alpha] == [(64 >> l, 64 >> l, 4) for l in range(7)]
    for a in pyr.alpha:                                  # α is a distribution per texel
        np.testing.assert_allclose(a.sum(axis=-1), 1.0, atol=1e-5)
    # finest level: one delta lobe with μ = n and κ at the cap
    al, mu, ka = texel_lobes(pyr, 0, 5, 9)
    j = int(np.argmax(al))
    assert al[j] == 1.0 and np.allclose(mu[j], grooves64[5, 9], atol=1e-6)
    assert ka[j] == pytest.approx(1e4, rel=1e-2)
    # a lookup at a texel centre and an integer lod returns the stored texel
    lev, r, c = 3, 2, 5
    m = 64 >> lev
    u, v = (c + 0.5) / m, 1.0 - (r + 0.5) / m
    al2, mu2, ka2 = lookup(pyr, u, v, lev)
    al1, mu1, ka1 = texel_lobes(pyr, lev, r, c)
    np.testing.assert_allclose(al2, al1, atol=1e-7)
    live = al1 > 0
    np.testing.assert_allclose(mu2[live], mu1[live], atol=1e-6)
    np.testing.assert_allclose(ka2[live], ka1[live], rtol=1e-4)
    # a groove texel at level 3 (8×8 normals, one period: two tilts): two lobes of ½ at ±36.9°
    al, mu, ka = texel_lobes(pyr, 3, 0, 0)
    big = np.sort(al)[-2:]
    np.testing.assert_allclose(big, [0.5, 0.5], atol=1e-6)
    assert sorted(np.round(mu[al > 0.25][:, 0], 6)) == [-0.6, 0.6]


def _pair_error(pyr, level, s=20.0):
    """Mean over horizontal neighbour pairs of the RMS (over ω) difference between the
    mixture of interpolated textures at the pair's midpoint and the mean of the two texels'
    shaded mixtures (eq 20 lobes): the error trilinear filtering of the textures makes."""
    th = np.radians(np.arange(0, 60, 6))
    ph = np.radians(np.arange(0, 360, 45))
    T, P = np.meshgrid(th, ph)
    om = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    a, ar = pyr.alpha[level].astype(float), pyr.alpha_r[level].astype(float)
    from sgpipe.normalmap.vmf import lobe_from_texel
    m = a.shape[0]
    errs = []
    for r in range(m):
        for c in range(m - 1):
            shade = []
            for aa, rr in ((a[r, c], ar[r, c]), (a[r, c + 1], ar[r, c + 1]),
                           (0.5 * (a[r, c] + a[r, c + 1]), 0.5 * (ar[r, c] + ar[r, c + 1]))):
                lob = [lobe_from_texel(aa[j], *rr[j]) for j in range(len(aa))]
                shade.append(mixture_blinn_phong([x[0] for x in lob], [x[1] for x in lob],
                                                 [x[2] for x in lob], s, om))
            errs.append(np.sqrt(np.mean((shade[2] - 0.5 * (shade[0] + shade[1])) ** 2)))
    return float(np.mean(errs))


def test_alignment_reduces_interpolation_error(grooves64):
    """Measured (64² grooves crop, levels 1–4): unaligned 0.208 / 0.422 / 0.085 / 0.182,
    slots matched only (C′ = 0) 0.023 / 0.053 / 0.044 / 0.073, with the eq 23 pull C′ = 4
    0.023 / 0.053 / 0.043 / 0.039."""
    un = fit_vmf_pyramid(grooves64, VMFSettings(lobes=4, align=False))
    al = fit_vmf_pyramid(grooves64, VMFSettings(lobes=4, align=True))
    for lev in (1, 2, 3, 4):
        e_al, e_un = _pair_error(al, lev), _pair_error(un, lev)
        assert e_al < 0.6 * e_un, (lev, e_al, e_un)
    # the eq 23 pull itself (beyond matching slots) helps where lobes are broad
    m0 = fit_vmf_pyramid(grooves64, VMFSettings(lobes=4, align_strength=0.0))
    m4 = fit_vmf_pyramid(grooves64, VMFSettings(lobes=4, align_strength=4.0))
    assert _pair_error(m4, 4) < 0.7 * _pair_error(m0, 4)


def test_deterministic_across_thread_counts(grooves64):
    t = get_num_threads()
    try:
        set_num_threads(1)
        a = fit_vmf_pyramid(grooves64)
        set_num_threads(t)
        b = fit_vmf_pyramid(grooves64)
    finally:
        set_num_threads(t)
    for x, y in zip(a.alpha + a.alpha_r, b.alpha + b.alpha_r):
        assert x.tobytes() == y.tobytes()


def test_bilinear_addressing_and_trilinear_blend(grooves64):
    """The lookup's addressing is the renderer's (tex_bilinear: repeat, v = 0 the bottom row,
    texel centres at half-integers) and a fractional lod blends α and α·r of the two levels
    linearly before κ and μ are recovered."""
    from sgpipe.normalmap.vmf import bilinear, lobe_from_texel
    tex = np.arange(4 * 4 * 2, dtype=float).reshape(4, 4, 2)
    # (u, v) = (0, 1 − 0.5/4): halfway between column 3 and column 0 (wrap), on row 0
    np.testing.assert_allclose(bilinear(tex, 0.0, 1.0 - 0.125), 0.5 * (tex[0, 3] + tex[0, 0]))
    np.testing.assert_allclose(bilinear(tex, 0.625, 0.125), tex[3, 2])   # bottom row = v ≈ 0
    pyr = fit_vmf_pyramid(grooves64, VMFSettings(lobes=4))
    u, v, lod = 0.37, 0.81, 2.25

    def texels(lev):
        t = np.concatenate([pyr.alpha[lev][..., None], pyr.alpha_r[lev]], -1).astype(float)
        return bilinear(t.reshape(t.shape[0], t.shape[1], -1), u, v).reshape(4, 4)

    t = 0.75 * texels(2) + 0.25 * texels(3)
    al, mu, ka = lookup(pyr, u, v, lod)
    for j in range(4):
        a, m, k = lobe_from_texel(*t[j])
        assert al[j] == pytest.approx(a, abs=1e-12) and ka[j] == pytest.approx(k, rel=1e-9)
        np.testing.assert_allclose(mu[j], m, atol=1e-12)
    np.testing.assert_allclose(al.sum(), 1.0, atol=1e-6)


def test_eq14_mixture_with_a_measured_brdf_vs_quadrature():
    """Eq 14 (vMF lobes × a tabulated D(θ_h) through ρ̂_l) equals the direct integral of the
    table's D against the two-lobe mixture."""
    from sgpipe.brdf.tabulated import NDF_THETA
    from sgpipe.normalmap.sh import beckmann_ndf, tabulated_coeffs
    from sgpipe.normalmap.vmf import mixture_zonal
    d = beckmann_ndf(np.cos(NDF_THETA), 0.3)
    rho = tabulated_coeffs(NDF_THETA, d / d[0], 48)     # scaled to ∫ D cos = 1

    def f(u):
        th = np.arccos(np.clip(u, -1, 1))
        return np.where(u > 0, np.interp(th, NDF_THETA, d / d[0]), 0.0)

    from sgpipe.normalmap.sh import zonal_coeffs
    scale = rho[0] / zonal_coeffs(f, 0)[0]               # the same scaling for the table
    alpha, mus, kappas = [0.7, 0.3], [_unit([0.3, 0, 0.95]), _unit([-0.4, 0.2, 0.9])], [30., 80.]
    th = np.linspace(-0.8, 0.8, 9)
    omega = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], -1)
    got = mixture_zonal(alpha, mus, kappas, rho, omega)
    want = sum(a * _convolve(lambda u: scale * f(u), m, k, omega)
               for a, m, k in zip(alpha, mus, kappas))
    np.testing.assert_allclose(got / want.max(), want / want.max(), atol=3e-3)
