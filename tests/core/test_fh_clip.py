"""core.fh_clip: the visible part of a clipped SG as one SG — its L2 objective against brute-force
quadrature over the sphere, the fit against eq 31's unmoved lobe, the stored table against
fresh fits, and the planar limit."""
import numpy as np
import pytest

from sgpipe.core import hemisphere_quadrature, sg_eval
from sgpipe.core import fh_clip as fc
from sgpipe.core.fh import fh_exact


def _brute(theta_d, lam, delta, lam2):
    """‖G·1 − A G'‖² / ‖G·1‖² by a product rule on the visible hemisphere and on the hidden
    one (polar axis ±q: the boundary is exact)."""
    q = np.array([0.0, 0.0, 1.0])
    p = np.array([np.cos(theta_d), 0.0, np.sin(theta_d)])
    p2 = np.array([np.cos(theta_d + delta), 0.0, np.sin(theta_d + delta)])
    a = fh_exact(theta_d, lam) / fc.sg_integral(lam2, 1.0)
    dv, wv = hemisphere_quadrature(200, 400, axis=q)
    dh, wh = hemisphere_quadrature(200, 400, axis=-q)
    vis = np.sum(wv * (sg_eval(dv, p, lam, 1.0) - a * sg_eval(dv, p2, lam2, 1.0)) ** 2)
    hid = np.sum(wh * (a * sg_eval(dh, p2, lam2, 1.0)) ** 2)
    return (vis + hid) / np.sum(wv * sg_eval(dv, p, lam, 1.0) ** 2)


@pytest.mark.parametrize("theta_d,lam,delta,lam2", [(0.0, 2.0, 0.5, 4.0), (-0.6, 0.3, 1.2, 2.0),
                                                     (0.4, 20.0, 0.1, 30.0),
                                                     (1.2, 0.05, 0.2, 1.0)])
def test_objective_is_the_relative_l2_error_by_quadrature(theta_d, lam, delta, lam2):
    assert fc.l2_objective(theta_d, lam, delta, lam2) == pytest.approx(
        _brute(theta_d, lam, delta, lam2), rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("lam", [0.1, 2.0, 10.0, 100.0])
@pytest.mark.parametrize("theta_d", [-0.3, 0.0, 0.3])
def test_fit_beats_eq31s_unmoved_lobe(lam, theta_d):
    """Where the boundary cuts the lobe, the moved and resharpened lobe is much closer to the
    visible part than eq 31's (same integral, same axis and sharpness)."""
    d, s = fc.clip_fit(theta_d, lam)
    fit = fc.l2_objective(theta_d, lam, d / np.sqrt(lam), lam * np.exp(s))
    eq31 = fc.l2_objective(theta_d, lam, 0.0, lam)
    if eq31 < 1e-3:                 # the boundary does not reach the lobe: nothing to move
        assert fit <= eq31 + 1e-9 and abs(d) < 0.05
    else:
        assert fit < 0.7 * eq31, (fit, eq31)
    # half a lobe (θ_d = 0): about a fifth of its squared norm left, eq 31 leaves half
    if theta_d == 0.0:
        assert eq31 == pytest.approx(0.5, rel=1e-6) and fit < 0.21


def test_fit_moves_the_lobe_off_the_boundary_and_sharpens_it():
    for lam in (0.5, 5.0, 50.0):
        d, s = fc.clip_fit(0.0, lam)
        assert 0.5 < d < 0.9 and 0.3 < s < 1.2             # units of σ = 1/√λ
    # a nearly uniform lobe: the visible hemisphere, a lobe about q
    d, s = fc.clip_fit(0.0, 0.05)
    assert d / np.sqrt(0.05) > 1.2 and 0.05 * np.exp(s) > 0.8


def test_sharp_lobes_approach_the_planar_limit():
    """At λ = 10⁴ the fit depends on a = θ_d √λ only, as the planar truncated Gaussian does."""
    for a in (-1.0, 0.0, 1.0):
        f1 = fc.clip_fit(a / 100.0, 1.0e4)
        f2 = fc.clip_fit(a / 50.0, 2.5e3)
        np.testing.assert_allclose(f1, f2, atol=3e-3)
    r, lv = fc.planar_clip(0.0, 1.0e4)
    assert r == pytest.approx(np.sqrt(2 / np.pi)) and lv == pytest.approx(-np.log(1 - 2 / np.pi))


def test_stored_table_is_the_fits_at_its_nodes():
    """A stale fh_clip_table.npz (grid or fit changed without `python -m sgpipe.core.fh_clip`)
    fails here."""
    tab = fc.load_table()
    th, lams = fc.table_grid()
    assert tab.shape == (fc.CLIP_NL, fc.CLIP_NT, 2) and np.isfinite(tab).all()
    rng = np.random.default_rng(3)
    rows, cols = rng.integers(0, fc.CLIP_NL, 12), rng.integers(fc.CLIP_NT // 3, fc.CLIP_NT, 12)
    for i, j in zip(rows, cols):
        got = fc.l2_objective(th[i, j], lams[i], tab[i, j, 0] / np.sqrt(lams[i]),
                              lams[i] * np.exp(tab[i, j, 1]))
        d, s = fc.clip_fit(th[i, j], lams[i], tuple(tab[i, j]))
        best = fc.l2_objective(th[i, j], lams[i], d / np.sqrt(lams[i]), lams[i] * np.exp(s))
        assert got <= best + 1e-6, (i, j)
