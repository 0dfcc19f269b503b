"""Wang09 §4 NDF lobes: eq 12, analytic equivalents, LM about +z, L-BFGS-B with free axes."""

from __future__ import annotations

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.brdf.ndf import TabulatedNDF
from sgpipe.fit.ndf_sg import fit_ndf_sg, ndf_error_curve


@pytest.mark.parametrize("m", [0.1, 0.2, 0.4])
def test_cook_torrance_reproduces_eq12(m):
    ndf = make_brdf("cook_torrance", {"m": m}).ndf_model
    sg = fit_ndf_sg(ndf)                                   # auto -> analytic
    assert sg.method == "analytic"
    assert sg.sharpness[0] == pytest.approx(2.0 / m**2) and sg.amplitude[0] == 1.0
    np.testing.assert_allclose(sg.axis, [[0, 0, 1.0]])
    assert sg.rel_l2 < 0.03                                # error vs exact NDF (reported)
    lm = fit_ndf_sg(ndf, method="lm", n_lobes=1)           # eq 12 is close to the L2 optimum
    assert lm.rel_l2 <= sg.rel_l2 + 1e-9
    assert lm.sharpness[0] == pytest.approx(2.0 / m**2, rel=0.05)


@pytest.mark.parametrize("model,params", [
    ("blinn_phong", {"exponent": 80}), ("ward", {"alpha": 0.15}), ("beckmann", {"alpha": 0.2}),
    ("ggx", {"alpha": 0.2}), ("ashikhmin_shirley", {"nu": 60, "nv": 60}),
    ("cook_torrance", {"m": 0.3})])
def test_analytic_sharpness_is_the_peak_curvature(model, params):
    """Derivation check: λ = −d ln D/d(h·n) at the pole, by finite differences of the exact D."""
    ndf = make_brdf(model, params).ndf_model
    lam = fit_ndf_sg(ndf, method="analytic").sharpness[0]
    c = 1.0 - 1e-6
    h = np.array([[np.sqrt(1 - c * c), 0.0, c], [0.0, 0.0, 1.0]])
    d = ndf.eval(h)
    assert (np.log(d[1]) - np.log(d[0])) / (1 - c) == pytest.approx(lam, rel=1e-3)


def test_lm_lobes_sorted_and_improve_heavy_tails():
    ndf = make_brdf("ggx", {"alpha": 0.2}).ndf_model
    one = fit_ndf_sg(ndf, method="lm", n_lobes=1)
    two = fit_ndf_sg(ndf, method="lm", n_lobes=2)
    assert np.all(np.diff(two.sharpness) > 0)              # Wang09: increasing sharpness
    assert two.rel_l2 < 0.5 * one.rel_l2
    curve = [f.rel_l2 for f in ndf_error_curve(ndf, 4)]
    assert all(b <= a + 1e-6 for a, b in zip(curve, curve[1:])), curve


def test_lm_on_tabulated_ndf():
    theta = ((np.arange(90) + 0.5) / 90) ** 2 * np.pi / 2
    m = 0.25
    ndf = TabulatedNDF(theta, np.exp(-(theta / m) ** 2))
    sg = fit_ndf_sg(ndf, method="lm", n_lobes=2)
    assert sg.rel_l2 < 0.01
    ref = fit_ndf_sg(make_brdf("cook_torrance", {"m": m}).ndf_model, method="lm", n_lobes=1)
    assert sg.rel_l2 <= ref.rel_l2 + 2e-3


def test_anisotropic_free_axis_lbfgsb():
    ndf = make_brdf("ward", {"alpha_u": 0.08, "alpha_v": 0.24}).ndf_model
    fits = ndf_error_curve(ndf, 4)
    errs = [f.rel_l2 for f in fits]
    assert all(b <= a + 1e-6 for a, b in zip(errs, errs[1:])), errs
    assert errs[-1] < 0.6 * errs[0]
    four = fits[-1]
    assert four.method == "lbfgsb" and four.axis.shape == (4, 3)
    # lobes spread along the long (y) axis of the anisotropic NDF
    assert np.ptp(four.axis[:, 1]) > 2 * np.ptp(four.axis[:, 0])
    np.testing.assert_allclose(np.linalg.norm(four.axis, axis=1), 1.0)
