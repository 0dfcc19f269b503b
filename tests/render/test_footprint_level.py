"""The texture footprint's MIP level (sgpipe.scene.footprint) against the analytic one: a
square plane facing the camera at distance D covers 2D·tan(fov/2)/H world units per pixel."""

import math

import numpy as np

from sgpipe.scene.camera import Camera
from sgpipe.scene.footprint import mip_level, uv_derivatives
from sgpipe.scene.gbuffer import TraceObject, trace_gbuffer

SIZE, SIDE, FOV, RES = 4.0, 1024, 30.0, 32


def _plane():
    h = SIZE / 2
    v = np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]], float)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    return TraceObject.mesh("plane", v, [[0, 1, 2], [0, 2, 3]], uvs=uv)


def _levels(dist, step=1.0):
    cam = Camera(eye=(0.0, 0.0, dist), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0),
                 fov_deg=FOV, width=RES, height=RES)
    gb = trace_gbuffer([_plane()], *cam.rays())
    assert gb.hit.all()
    return mip_level(uv_derivatives(cam, gb, step=step), SIDE)


def _analytic(dist, step=1.0):
    # the pixel's world size at the plane's centre (the level varies slowly across the frame)
    return math.log2(2 * dist * math.tan(math.radians(FOV) / 2) / RES * step * SIDE / SIZE)


def test_level_matches_log2_texels_per_pixel():
    lev = _levels(3.0)
    c = lev[RES // 2 - 1:RES // 2 + 1, RES // 2 - 1:RES // 2 + 1]
    assert np.all(np.abs(c - _analytic(3.0)) < 0.05), (c, _analytic(3.0))


def test_level_grows_by_one_when_the_distance_doubles():
    a, b = _levels(2.0), _levels(4.0)
    c = (slice(RES // 2 - 1, RES // 2 + 1),) * 2
    assert np.all(np.abs(b[c] - a[c] - 1.0) < 0.05)
    assert np.all(np.abs(a[c] - _analytic(2.0)) < 0.05)


def test_supersample_step_lowers_the_level():
    a, b = _levels(3.0), _levels(3.0, step=0.25)
    assert np.allclose(a - b, 2.0, atol=1e-4)


def test_grazing_plane_footprint_is_larger_along_the_view():
    cam = Camera(eye=(0.0, -3.0, 0.5), target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0),
                 fov_deg=FOV, width=RES, height=RES)
    gb = trace_gbuffer([_plane()], *cam.rays())
    duv = uv_derivatives(cam, gb)[gb.hit]
    ly = np.hypot(duv[:, 2], duv[:, 3])
    lx = np.hypot(duv[:, 0], duv[:, 1])
    assert np.all(ly > 2.0 * lx)      # foreshortened along the view: anisotropic footprint
