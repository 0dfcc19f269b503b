"""Light fits for diffuse: SG mixture (Wang09 §6) and SH (Green06) against exact irradiance."""
import math

import numpy as np
import pytest

from sgpipe.core.maps import cubemap_texel_dirs, latlong_solid_angles, latlong_texel_dirs
from sgpipe.core.sh import sh_eval
from sgpipe.envmap import lightfit

from .envmap_helpers import sky_sun_cube


def test_exact_irradiance_of_constant_map_is_pi():
    e = lightfit.irradiance_map(np.ones((6, 32, 32, 3)), 8, 16)
    np.testing.assert_allclose(e, math.pi, rtol=2e-3)


def test_sh_projection_and_irradiance_of_band_limited_map():
    d = cubemap_texel_dirs(64)
    coef = np.zeros((25, 3))
    coef[0] = [1.0, 0.8, 0.6]
    coef[2] = [0.3, 0.2, 0.1]                # l = 1 (z)
    coef[6] = [0.2, 0.1, 0.05]               # l = 2
    cube = sh_eval(d, 4) @ coef + 0.0
    sh = lightfit.sh_light(cube, 4)
    np.testing.assert_allclose(sh["coeffs"], coef, atol=2e-3)
    n = latlong_texel_dirs(8, 16)
    exact = lightfit.irradiance_map(cube, 8, 16)
    np.testing.assert_allclose(lightfit.sh_irradiance(sh["irradiance_coeffs"], n), exact,
                               rtol=5e-3, atol=5e-3)


def test_sg_fit_recovers_sg_environment():
    d = cubemap_texel_dirs(32)
    true = lightfit.SGLight(np.array([[0.0, 1.0, 0.0], [0.8, 0.2, 0.566]]),
                            np.array([3.0, 40.0]), np.array([[0.5, 0.6, 0.9], [8.0, 7.0, 5.0]]))
    cube = true.radiance(d)
    fit = lightfit.fit_sg_light(cube, 3)
    n = latlong_texel_dirs(16, 32)
    w = latlong_solid_angles(16, 32)
    err = lightfit.rel_rms(fit.irradiance_exact(n), true.irradiance_exact(n), w)
    assert np.all(err < 0.01), err


def test_sg_fit_keeps_tiny_sun_power_and_irradiance():
    cube = sky_sun_cube(32)
    fit = lightfit.fit_sg_light(cube, 5)
    assert len(fit.sharpness) == 5 and np.all(fit.amplitude >= 0)
    n = latlong_texel_dirs(16, 32)
    w = latlong_solid_angles(16, 32)
    exact = lightfit.irradiance_map(cube, 16, 32)
    err = lightfit.rel_rms(fit.irradiance_exact(n), exact, w)
    assert np.all(err < 0.03), err
    sh = lightfit.sh_light(cube, 4)
    err_sh = lightfit.rel_rms(lightfit.sh_irradiance(sh["irradiance_coeffs"], n), exact, w)
    assert np.all(err_sh < 0.06), err_sh


def test_sg_fit_rejects_ten_lobes():
    with pytest.raises(ValueError):
        lightfit.fit_sg_light(np.ones((6, 8, 8, 3)), 10)


@pytest.mark.parametrize("lam_true", [300.0, 1500.0])
def test_sg_fit_recovers_sharpness_of_small_source(lam_true):
    # Regression: through the λ_b = 16 blur a sharp lobe's λ is unidentifiable and the fit left a
    # small sun ~4-10x too broad (demo: λ 313 for a 0.75° sun), so its shadows came out far too
    # soft. The sharp lobes must keep the source's width: E[1 - d·p] = 1/λ on the fine texels.
    d = cubemap_texel_dirs(64)
    p = np.array([0.77, 0.574, 0.28]) / np.linalg.norm([0.77, 0.574, 0.28])
    true = lightfit.SGLight(np.array([[0.0, 1.0, 0.0], p]), np.array([1.0, lam_true]),
                            np.array([[0.3, 0.3, 0.3], [lam_true, lam_true, lam_true]]))
    fit = lightfit.fit_sg_light(true.radiance(d), 4)
    near = fit.axes @ p > np.cos(0.1)
    power = fit.amplitude[near, 0] * 2 * np.pi / fit.sharpness[near]
    lam_eff = power.sum() / (power / fit.sharpness[near]).sum()   # power-weighted 1/λ
    assert abs(power.sum() / (2 * np.pi) - 1.0) < 0.05, power.sum()
    assert 0.7 < lam_eff / lam_true < 1.4, (fit.sharpness, fit.amplitude)
