"""Han07 Fig 7's pieces (sgpipe.experiments.han07_ndf, sgpipe.normalmap.quality): the vMF
mixture's SH coefficients against quadrature of its density (Funk–Hecke with i_l(κ)/i_0(κ)),
the NDF error against quadrature of the band-limited difference on the sphere, and the quick
run's curve on one grooves cell: more lobes never fit worse."""

import numpy as np
import pytest

from sgpipe.core.sh import sh_eval
from sgpipe.core.vmf import vmf_pdf
from sgpipe.experiments import han07_ndf as ndf
from sgpipe.normalmap import quality as Q

from .quadrature import polar_rule

LMAX = 8


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def test_mixture_sh_is_the_projection_of_the_mixture_density():
    """γ_lm of Σ α_j vMF(μ_j, κ_j) (closed form) = ∫ p(ω) Y_lm(ω) dω by quadrature."""
    alpha = np.array([0.5, 0.3, 0.2])
    mu = np.array([_unit([0.3, 0.1, 0.9]), _unit([-0.5, 0.2, 0.8]), _unit([0.0, -0.6, 0.8])])
    kappa = np.array([40.0, 12.0, 150.0])
    d, w = polar_rule(n_beta=1200, n_phi=720)
    dens = sum(a * vmf_pdf(d, m, k) for a, m, k in zip(alpha, mu, kappa))
    want = (w * dens) @ sh_eval(d, LMAX)
    np.testing.assert_allclose(Q.mixture_sh(alpha, mu, kappa, LMAX), want, atol=2e-4)
    # Eq 19's Gaussian e^{−l²/2κ} in place of the exact coefficients is measurably off
    from sgpipe.core.sh import sh_expand_bands
    from sgpipe.normalmap.lobes import vmf_zonal_eq19
    eq19 = sum(a * sh_expand_bands(vmf_zonal_eq19(k, LMAX)) * sh_eval(m[None], LMAX)[0]
               for a, m, k in zip(alpha, mu, kappa))
    assert np.abs(eq19 - want).max() > 50 * 2e-4


@pytest.fixture(scope="module")
def quick_curve():
    """Fig 7 of the quick run: the grooves map's top-left 64² cell (one level-6 texel)."""
    label, normals = ndf.fig7_pieces(full=False)[0]
    return normals, ndf.fig7_curve(normals, size=48)


def test_fig7_ndf_error_matches_quadrature(quick_curve):
    """The J = 4 row's NDF error = √(∫ (f_mix − f_data)² / ∫ f_data²) of the band-limited NDFs
    evaluated on a quadrature grid (Parseval holds for the basis used)."""
    from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid, texel_lobes
    normals, curve = quick_curve
    pyr = fit_vmf_pyramid(normals, VMFSettings(lobes=4))
    al, mu, ka = texel_lobes(pyr, len(pyr.alpha) - 1, 0, 0)
    d, w = polar_rule(n_beta=600, n_phi=360)
    y = sh_eval(d, LMAX)
    f_data = y @ Q.ndf_sh(normals, LMAX)
    f_mix = y @ Q.mixture_sh(al, mu, ka, LMAX)
    want = np.sqrt(np.sum(w * (f_mix - f_data) ** 2) / np.sum(w * f_data ** 2))
    row = next(r for r in curve["rows"] if r["lobes"] == 4)
    assert row["ndf_error"] == pytest.approx(want, rel=1e-6)


def test_fig7_more_lobes_never_fit_worse(quick_curve):
    """The quick run's curve: NDF error and lit-sphere error non-increasing in J (one cell:
    two groove normals and a cap), every lobe used, one lobe far off and eight close."""
    normals, curve = quick_curve
    rows = curve["rows"]
    assert [r["lobes"] for r in rows] == list(range(1, 9))
    ndf_err = np.array([r["ndf_error"] for r in rows])
    img_err = np.array([r["image_rel_l2"] for r in rows])
    assert np.all(np.diff(ndf_err) <= 1e-9), ndf_err
    assert np.all(np.diff(img_err) <= 1e-9), img_err
    assert [r["used_lobes"] for r in rows] == list(range(1, 9))
    assert ndf_err[0] > 0.5 and ndf_err[-1] < 0.05
    # the image truth is the mean over the texel's normals, duplicates merged or not
    mask, h, cos = Q.lit_sphere_half_vectors(16, ndf.FIG7_LIGHT)
    direct = np.mean(Q._lobe(h @ normals.reshape(-1, 3).T, 60.0), axis=1)
    np.testing.assert_allclose(Q.texel_blinn_phong(normals, 60.0, h), direct, rtol=1e-10)
