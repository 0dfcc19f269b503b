"""SH9 irradiance JSON against quadrature of the irradiance of known maps."""

import json

import numpy as np
import pytest

from sgpipe.core.maps import cubemap_texel_dirs
from sgpipe.core.quadrature import hemisphere_quadrature
from sgpipe.core.sh import sh_eval
from sgpipe.errors import BadInput
from sgpipe.export import sh9

from .export_helpers import spot_cube, write_envmap


def _normals(k=40):
    d = np.random.default_rng(9).normal(size=(k, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _irradiance(radiance, n):
    """E(n) = ∫ L(ω) max(0, n·ω) dω, Gauss–Legendre over the hemisphere about n."""
    d, w = hemisphere_quadrature(96, 192, axis=n)
    return ((d @ n) * w) @ radiance(d)


def test_basis_functions_are_sgpipe_sh_in_world_coordinates():
    d = _normals(200)
    np.testing.assert_allclose(sh9.sh9_basis(d), sh_eval(d, 2), atol=1e-15)


def test_band_limited_map_irradiance_is_exact(tmp_path):
    """L = a + b·y + c·xz (bands ≤ 2): E from the nine coefficients is the quadrature's."""
    def radiance(d):
        v = 1.0 + 0.6 * d[:, 1] + 0.9 * d[:, 0] * d[:, 2]
        return np.stack([v, 0.5 * v, 0.25 * v], -1)
    cube = radiance(cubemap_texel_dirs(64).reshape(-1, 3)).reshape(6, 64, 64, 3)
    write_envmap(tmp_path, cube)
    doc = json.loads(json.dumps(sh9.sh9_document(tmp_path / "envmap")))
    irr = np.array(doc["irradiance"])
    assert irr.shape == (9, 3) and np.array(doc["radiance"]).shape == (9, 3)
    for n in _normals(12):
        np.testing.assert_allclose(sh9.sh9_irradiance(irr, n), _irradiance(radiance, n),
                                   rtol=2e-4)
    # the cosine convolution is applied: E_00 = π L_00, E_1m = 2π/3 L_1m, E_2m = π/4 L_2m
    rad = np.array(doc["radiance"])
    np.testing.assert_allclose(irr, rad * np.repeat([np.pi, 2 * np.pi / 3, np.pi / 4],
                                                    [1, 3, 5])[:, None], rtol=1e-12)


def test_spot_map_irradiance_within_the_order_2_error(tmp_path):
    """A map with bright spots: nine coefficients hold E to a few % (Ramamoorthi–Hanrahan);
    measured ≤ 2.8 % of the mean irradiance here."""
    from .test_prefilter import spot_radiance
    write_envmap(tmp_path, spot_cube(64))
    irr = np.array(sh9.sh9_document(tmp_path / "envmap")["irradiance"])
    ns = _normals(24)
    ref = np.array([_irradiance(spot_radiance, n) for n in ns])
    err = np.abs(sh9.sh9_irradiance(irr, ns) - ref) / ref.mean(0)
    assert err.max() < 0.035


def test_lmax_below_two_is_bad_input(tmp_path):
    write_envmap(tmp_path, spot_cube(16), sh_lmax=1)
    with pytest.raises(BadInput, match="lmax is 1") as e:
        sh9.sh9_document(tmp_path / "envmap")
    assert e.value.key == "envmap.sh_lmax" and e.value.file.endswith("light_sh.npz")
