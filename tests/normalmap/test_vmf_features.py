"""Han07 §7.3 eq 22: the vMF pyramid's lobes carry the responsibility-weighted mean of their
normals' feature vectors (colour, material parameters), so a coarse texel keeps which colour
belongs to which normal cluster where the plain MIP of the colour mixes them."""

import numpy as np
import pytest

from sgpipe.normalmap.bilinear import bilinear_normals
from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid, lookup, lookup_features

RED, BLUE = np.array([0.9, 0.1, 0.05]), np.array([0.05, 0.2, 0.9])


def _two_cluster_map(n=32, seed=0):
    """Normals tilted ±35° about y in a random checker of texels (each with a little jitter),
    the +x facets red with roughness 0.2, the −x facets blue with roughness 0.6."""
    rng = np.random.default_rng(seed)
    side = rng.random((n, n)) < 0.5
    t = np.radians(35.0) * np.where(side, 1.0, -1.0) + rng.normal(0, 0.03, (n, n))
    p = rng.normal(0, 0.03, (n, n))
    nrm = np.stack([np.sin(t) * np.cos(p), np.sin(p), np.cos(t) * np.cos(p)], -1)
    feat = np.where(side[..., None], np.append(RED, 0.2), np.append(BLUE, 0.6))
    return nrm, feat, side


@pytest.mark.parametrize("align", [True, False])
def test_lobes_keep_their_clusters_colour_and_the_mean_is_conserved(align):
    """Every level ≥ 1: Σ_j α_j f_j is the box mean of the features the texel covers (EM's
    responsibilities sum to one per normal: exact to float32), and at the top level the lobe
    about +x carries the red facets' features, the one about −x the blue ones' (within 0.01),
    where the plain mean is their mix."""
    nrm, feat, side = _two_cluster_map()
    pyr = fit_vmf_pyramid(nrm, VMFSettings(lobes=2, align=align), features=feat)
    assert pyr.alpha_f is not None and len(pyr.alpha_f) == len(pyr.alpha)
    for lev in range(1, len(pyr.alpha)):
        m = nrm.shape[0] >> lev
        box = feat.reshape(m, 1 << lev, m, 1 << lev, 4).mean((1, 3))
        np.testing.assert_allclose(pyr.alpha_f[lev].sum(2), box, atol=2e-6)
    # level 0: each texel's own features in its one lobe
    np.testing.assert_allclose(pyr.alpha_f[0].sum(2), feat, atol=1e-6)
    top = len(pyr.alpha) - 1
    al, mu, _ = lookup(pyr, 0.5, 0.5, top)
    f = lookup_features(pyr, 0.5, 0.5, top)
    plus = int(np.argmax(mu[:, 0]))
    assert mu[plus, 0] > 0.5 and mu[1 - plus, 0] < -0.5
    np.testing.assert_allclose(f[plus], np.append(RED, 0.2), atol=0.01)
    np.testing.assert_allclose(f[1 - plus], np.append(BLUE, 0.6), atol=0.01)
    np.testing.assert_allclose(al[plus], side.mean(), atol=0.01)
    mix = feat.mean((0, 1))
    assert np.abs(mix[:3] - RED).max() > 0.3          # the plain MIP mixes the clusters


def test_features_do_not_move_the_lobes():
    """The E-step reads the normals alone: the α and α·r textures with features are those
    without, bit for bit; with sub-sampled normals (`fine`) each sub-sample takes its texel's
    features and the box-mean identity holds per level."""
    nrm, feat, _ = _two_cluster_map(16, seed=3)
    plain = fit_vmf_pyramid(nrm, VMFSettings(lobes=3))
    withf = fit_vmf_pyramid(nrm, VMFSettings(lobes=3), features=feat)
    assert plain.alpha_f is None
    for a, b in zip(plain.alpha + plain.alpha_r, withf.alpha + withf.alpha_r):
        np.testing.assert_array_equal(a, b)
    fine = bilinear_normals(nrm, 2)
    sub = fit_vmf_pyramid(nrm, VMFSettings(lobes=3), fine=fine, features=feat)
    for lev in range(1, len(sub.alpha)):
        m = nrm.shape[0] >> lev
        box = feat.reshape(m, 1 << lev, m, 1 << lev, 4).mean((1, 3))
        np.testing.assert_allclose(sub.alpha_f[lev].sum(2), box, atol=2e-6)
    with pytest.raises(ValueError, match="features"):
        fit_vmf_pyramid(nrm, VMFSettings(lobes=3), features=feat[:8])
