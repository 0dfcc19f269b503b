"""Single-lobe baselines from the mean normal: normalised MIP, Toksvig 2005, the engine bake."""

import numpy as np
import pytest

from sgpipe.core.vmf import kappa_from_rbar, mean_resultant_length
from sgpipe.normalmap import pyramid as P
from sgpipe.normalmap.lobes import convolved_sigma

from .helpers import tilted_normals
from .quadrature import vmf_samples_stratified


def test_mean_pyramid_levels_and_texel_normals():
    n = tilted_normals(16, seed=4)
    pyr = P.mean_normal_pyramid(n)
    assert [a.shape[0] for a in pyr] == [16, 8, 4, 2, 1] and P.level_count(16) == 5
    assert P.level_count(16, 3) == 3 and len(P.mean_normal_pyramid(n, 3)) == 3
    np.testing.assert_allclose(pyr[2][1, 3], P.texel_normals(n, 2, 1, 3).mean(0), atol=1e-15)
    np.testing.assert_allclose(pyr[4][0, 0], n.reshape(-1, 3).mean(0), atol=1e-15)


def test_v_groove_baselines_closed_form():
    """A 2×2 V-groove (Han07 Fig 1): normals (±s, 0, c) average to (0, 0, c)."""
    s, c = 0.6, 0.8
    n = np.array([[[s, 0, c], [-s, 0, c]], [[s, 0, c], [-s, 0, c]]])
    mean = P.mean_normal_pyramid(n)[1]
    np.testing.assert_allclose(P.normalized_mip(mean)[0, 0], [0, 0, 1], atol=1e-15)
    assert P.toksvig_factor(mean, 32.0)[0, 0] == pytest.approx(c / (c + 32.0 * (1 - c)))
    kappa = (3 * c - c ** 3) / (1 - c * c)
    assert P.engine_kappa(mean, 1e4)[0, 0] == pytest.approx(kappa)
    assert P.engine_roughness(mean, 0.1, 1e4)[0, 0] == pytest.approx(
        np.sqrt(0.01 + 2 / kappa))
    # eq 21 with α = 2σ is the engine's formula
    assert 2 * convolved_sigma(0.05, kappa) == pytest.approx(np.sqrt(0.01 + 2 / kappa))
    # a flat texel: κ capped, α′ → α
    flat = P.mean_normal_pyramid(np.tile([0.0, 0, 1], (2, 2, 1)))[1]
    assert P.engine_kappa(flat, 1e4)[0, 0] == 1e4


def test_engine_kappa_of_a_vmf_texel():
    """The mean of vMF(κ) draws has length A(κ) (eq 16), so the bake's κ is Banerjee(A(κ)):
    κ within 6 % (Banerjee(A(κ)) = 5.25 for κ = 5, 50.5 for 50)."""
    for kappa in (5.0, 50.0, 500.0):
        x = vmf_samples_stratified([0.1, 0.3, 0.9], kappa, 64).reshape(64, 64, 3)
        got = P.engine_kappa(P.mean_normal_pyramid(x)[-1], 1e6)[0, 0]
        assert got == pytest.approx(float(kappa_from_rbar(mean_resultant_length(kappa))),
                                    rel=1e-2)
        assert got == pytest.approx(kappa, rel=0.06)
