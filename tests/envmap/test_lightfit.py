"""Light fits for diffuse: SG mixture (Wang09 §6) and SH (Green06) against exact irradiance."""
import math

import numpy as np
import pytest

from sgpipe.core.maps import (cubemap_solid_angles, cubemap_texel_dirs, latlong_solid_angles,
                              latlong_texel_dirs)
from sgpipe.core.quadrature import lobe_quadrature
from sgpipe.core.sh import sh_eval
from sgpipe.envmap import lightfit
from sgpipe.envmap._lightfit_jit import sg_blur_sums

from .envmap_helpers import SUN, boxes_cube, sky_sun_cube


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


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


def test_compiled_texel_sums_match_dense_numpy():
    rng = np.random.default_rng(3)
    d = _unit(rng.normal(size=(3000, 3)))
    e = rng.random((3000, 3)) * np.array([1.0, 30.0, 0.01])
    q = _unit(rng.normal(size=(200, 3)))
    ref = np.maximum(q @ d.T, 0.0) @ e
    np.testing.assert_allclose(lightfit.irradiance(d, np.ones(3000), e, q), ref, rtol=1e-12)
    for lam in (0.5, 16.0, 32.0):          # the polynomial e^x: exact to ~1e-13 on [−2λ, 0]
        ref = np.exp(lam * (q @ d.T - 1.0)) @ e
        got = sg_blur_sums(q, np.ascontiguousarray(d.T), np.ascontiguousarray(e.T), lam)
        np.testing.assert_allclose(got, ref, rtol=1e-11)


@pytest.mark.parametrize("lam", [0.5, 3.0, 60.0, 4096.0])
def test_sg_irradiance_exact_matches_2d_quadrature(lam):
    # The azimuth is integrated in closed form; the reference is a dense 2-D product rule of
    # G(ω) max(0, n·ω), normals spread over the sphere and packed near the lobe's terminator.
    p = _unit([0.3, -0.5, 0.8])
    rng = np.random.default_rng(5)
    t = rng.normal(size=(150, 3))
    t = _unit(t - (t @ p)[:, None] * p)
    a = rng.uniform(-0.08, 0.08, 150)[:, None]
    normals = np.concatenate([_unit(rng.normal(size=(100, 3))), np.cos(a) * t + np.sin(a) * p,
                              [p, -p]])
    dirs, w = lobe_quadrature(p, lam, n_per_panel=32, n_phi=1024)
    ref = np.maximum(normals @ dirs.T, 0.0) @ (w * np.exp(lam * (dirs @ p - 1.0)))
    sg = lightfit.SGLight(p[None], np.array([lam]), np.array([[1.0, 2.0, 0.5]]))
    got = sg.irradiance_exact(normals)
    np.testing.assert_allclose(got, ref[:, None] * [1.0, 2.0, 0.5], rtol=0,
                               atol=1e-4 * ref.max() * 2.0)


def test_blurred_fit_gradient_matches_finite_differences():
    # Analytic Gauss–Newton pieces of the projected (NNLS μ) cost vs central differences.
    q = cubemap_texel_dirs(8).reshape(-1, 3)
    w = cubemap_solid_angles(8).reshape(-1)
    axes = _unit(np.array([[0.1, 1.0, 0.2], [0.8, 0.3, -0.5], [-0.6, 0.1, 0.7]]))
    true = lightfit.SGLight(axes, np.array([2.0, 30.0, 9.0]),
                            np.array([[1.0, 0.8, 0.6], [20.0, 18.0, 15.0], [3.0, 4.0, 5.0]]))
    target = true.radiance(q)
    prob = lightfit._BlurredFit(q, w, target, 16.0)
    x_axes = _unit(axes + [[0.05, 0.0, -0.03], [0.0, 0.06, 0.02], [-0.04, 0.0, 0.05]])
    x_s = np.log([2.6, 21.0, 12.0])
    frames = lightfit._tangent_frames(x_axes)
    state = prob.eval(x_axes, x_s)
    assert np.all(state[1] > 0)
    grad, _ = prob.system(x_axes, x_s, frames, state)

    def cost(step):
        k = len(x_s)
        ax = _unit(x_axes + step[:k, None] * frames[0] + step[k:2 * k, None] * frames[1])
        return prob.eval(ax, x_s + step[2 * k:])[0]

    h = 1e-6
    fd = np.array([(cost(h * e) - cost(-h * e)) / (2 * h) for e in np.eye(9)])
    np.testing.assert_allclose(grad, fd, rtol=1e-4, atol=1e-6 * np.abs(fd).max())


def _irradiance_error(fit, cube):
    """Relative RMS (per channel) of the fit's irradiance vs the exact texel quadrature on a
    32×16 lat-long grid of normals."""
    n = latlong_texel_dirs(16, 32)
    w = latlong_solid_angles(16, 32)
    return lightfit.rel_rms(fit.irradiance_exact(n), lightfit.irradiance_map(cube, 16, 32), w)


def test_sg_fit_small_source_irradiance_direction_and_power():
    # Sky + a 3-texel sun at 64² (as in the samples): the 8-lobe fit's irradiance vs the exact
    # texel quadrature, and the sun lobe's direction and power vs the texels'.
    cube = sky_sun_cube(64)
    fit = lightfit.fit_sg_light(cube, 8)
    err = _irradiance_error(fit, cube)
    assert np.all(err < 0.0015), err
    d = cubemap_texel_dirs(64)
    om = cubemap_solid_angles(64)
    hot = d @ SUN >= np.sort((d @ SUN).ravel())[-3]
    power_true = 2e4 * np.array([1.0, 0.9, 0.8]) * om[hot].sum()
    centroid = _unit((om[hot][:, None] * d[hot]).sum(0))
    near = fit.axes @ SUN > np.cos(0.05)
    power = fit.amplitude[near] * 2 * np.pi / fit.sharpness[near][:, None]
    axis = _unit((power.sum(1)[:, None] * fit.axes[near]).sum(0))
    np.testing.assert_allclose(power.sum(0), power_true, rtol=0.015)
    assert np.arccos(min(1.0, axis @ centroid)) < 0.004
    assert np.all(fit.sharpness[near] >= 2000.0), fit.sharpness


def test_sg_fit_boxes_irradiance_and_determinism():
    cube = boxes_cube(32)
    fit = lightfit.fit_sg_light(cube, 5)
    err = _irradiance_error(fit, cube)
    assert np.all(err < 0.01), err
    again = lightfit.fit_sg_light(cube, 5)
    for a, b in ((fit.axes, again.axes), (fit.sharpness, again.sharpness),
                 (fit.amplitude, again.amplitude)):
        assert np.array_equal(a, b)
