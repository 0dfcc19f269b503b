"""Camera rays (docs/CONVENTIONS.md) and the Embree + analytic-sphere G-buffer."""

import math

import numpy as np
import pytest

from sgpipe.errors import BadInput
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import GBuffer, TraceObject, Tracer, trace_gbuffer


def test_centre_ray_looks_at_target_and_corners_match_fov():
    cam = Camera(eye=(1.0, 2.0, 3.0), target=(0.0, 0.5, -1.0), fov_deg=50.0, width=41, height=31)
    o, d = cam.rays()
    assert o.shape == d.shape == (31, 41, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-6)
    fwd = np.subtract(cam.target, cam.eye) / np.linalg.norm(np.subtract(cam.target, cam.eye))
    np.testing.assert_allclose(d[15, 20], fwd, atol=1e-6)  # odd size: the centre pixel
    r, u, f = cam.basis()
    # Top edge of the image (pixel row 0 with oy = 0) is fov/2 above the axis.
    _, dtop = cam.rays(offset=(0.5, 0.0))
    col = 20
    ang = math.degrees(math.atan2(dtop[0, col] @ u, dtop[0, col] @ f))
    assert ang == pytest.approx(25.0, abs=1e-4)
    # Row 0 is the top (+up), column 0 the left (−right).
    assert d[0, 20] @ u > 0 and d[-1, 20] @ u < 0
    assert d[15, 0] @ r < 0 and d[15, -1] @ r > 0


def test_project_inverts_rays_and_jitter_stays_in_pixel():
    cam = Camera(eye=(0, 1, 4), target=(0, 0.5, 0), width=16, height=12, fov_deg=35)
    o, d = cam.rays()
    px = cam.project(o + 3.0 * d)
    jj, ii = np.meshgrid(np.arange(16) + 0.5, np.arange(12) + 0.5)
    np.testing.assert_allclose(px[..., 0], jj, atol=1e-4)
    np.testing.assert_allclose(px[..., 1], ii, atol=1e-4)
    oj, dj = cam.rays(jitter=np.random.default_rng(1))
    pj = cam.project(oj + 2.0 * dj)
    assert np.all(np.abs(pj[..., 0] - jj) <= 0.5 + 1e-4)
    assert np.all(np.abs(pj[..., 1] - ii) <= 0.5 + 1e-4)


def test_from_spec_and_bad_camera():
    cam = Camera.from_spec({"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0],
                            "fov_deg": 30, "width": 8, "height": 4})
    assert cam.shape == (4, 8)
    with pytest.raises(BadInput):
        Camera(eye=(0, 0, 0), target=(0, 0, 0))
    with pytest.raises(BadInput):
        Camera(eye=(0, 0, 0), target=(0, 1, 0), up=(0, 1, 0))


def _scene():
    floor = TraceObject.mesh("floor", [[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5]],
                             [[0, 2, 1], [0, 3, 2]], uvs=[[0, 0], [1, 0], [1, 1], [0, 1]])
    ball = TraceObject.sphere("ball", (0.0, 0.5, 0.0), 0.5)
    return [floor, ball]


def test_gbuffer_sphere_and_floor_geometry():
    cam = Camera(eye=(0, 1.5, 4), target=(0, 0.4, 0), width=48, height=40, fov_deg=40)
    o, d = cam.rays()
    objs = _scene()
    gb = trace_gbuffer(objs, o, d)
    assert isinstance(gb, GBuffer) and gb.shape == (40, 48)
    on_ball = gb.object_id == 1
    on_floor = gb.object_id == 0
    assert on_ball.sum() > 50 and on_floor.sum() > 50 and (~gb.hit).sum() > 0
    # Positions lie on the surfaces, along the rays, with the analytic normals.
    p = gb.position[on_ball]
    np.testing.assert_allclose(np.linalg.norm(p - [0, 0.5, 0], axis=1), 0.5, atol=1e-5)
    np.testing.assert_allclose(gb.normal[on_ball], (p - [0, 0.5, 0]) / 0.5, atol=1e-5)
    np.testing.assert_allclose(gb.position[on_floor][:, 1], 0.0, atol=1e-5)
    np.testing.assert_allclose(gb.normal[on_floor], [[0, 1, 0]] * on_floor.sum(), atol=1e-6)
    hitp = o[gb.hit] + gb.t[gb.hit][:, None] * d[gb.hit]
    np.testing.assert_allclose(hitp, gb.position[gb.hit], atol=1e-4)
    # Frames: unit, orthogonal, b = n × t; sphere tangent is azimuthal about +Y.
    n, t, b = gb.normal[gb.hit], gb.tangent[gb.hit], gb.bitangent[gb.hit]
    np.testing.assert_allclose(np.sum(n * t, -1), 0.0, atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(t, axis=-1), 1.0, atol=1e-5)
    np.testing.assert_allclose(b, np.cross(n, t), atol=1e-5)
    assert np.all(np.abs(gb.tangent[on_ball][:, 1]) < 1e-5)
    # Floor uv = barycentric interpolation of the vertex uvs: u = (x + 5)/10, v = (z + 5)/10.
    pf = gb.position[on_floor]
    np.testing.assert_allclose(gb.uv[on_floor], np.stack([(pf[:, 0] + 5) / 10,
                                                          (pf[:, 2] + 5) / 10], -1), atol=1e-5)
    assert set(np.unique(gb.triangle_id[on_floor])) <= {0, 1}
    assert np.all(gb.triangle_id[on_ball] == -1) and np.all(gb.object_id[~gb.hit] == -1)


def test_interpolate_and_occlusion():
    objs = _scene()
    o = np.array([[0.3, 2.0, 0.2], [3.0, 2.0, 3.0]])
    d = np.array([[0.0, -1.0, 0.0], [0.0, -1.0, 0.0]])
    gb = Tracer(objs).trace(o, d)
    assert gb.object_id.tolist() == [1, 0]
    vals = gb.interpolate([np.array([[0.0], [10.0], [20.0], [30.0]]), None])
    # floor hit at (3, 0, 3): value is linear in the vertex attribute → bilinear-free check
    f = objs[0]
    tri = f.faces[gb.triangle_id[1]]
    b0, b1 = gb.barycentrics[1]
    expect = (1 - b0 - b1) * 10 * tri[0] + b0 * 10 * tri[1] + b1 * 10 * tri[2]
    assert vals[1, 0] == pytest.approx(expect, abs=1e-4) and vals[0, 0] == 0.0
    tr = Tracer(objs)
    blocked = tr.occluded(np.array([[0, 0.01, -2.0], [0, 0.01, -2.0], [2, 0.01, 2]]),
                          np.array([[0, 0, 1.0], [0, 0, -1.0], [0, 1.0, 0]]),
                          tmax=np.array([10.0, 10.0, 10.0]))
    assert blocked.tolist() == [True, False, False]
    # tmax stops before the sphere
    assert not tr.occluded(np.array([[0, 0.5, -2.0]]), np.array([[0, 0, 1.0]]), tmax=1.0)[0]


def test_rays_at_continuous_positions_match_rays():
    """rays_at(column + ox, row + oy) gives the bits of rays(offset=(ox, oy)); positions outside
    the pixel (wide pixel filters) extrapolate the same projection (project() inverts it)."""
    import numpy as np
    from sgpipe.scene.camera import Camera
    cam = Camera(eye=(0.3, 1.1, 3.7), target=(0.1, 0.4, 0.0), fov_deg=37, width=9, height=7)
    for off in ((0.5, 0.5), (0.1, 0.8)):
        o, d = cam.rays(offset=off)
        i, j = np.indices((7, 9))
        o2, d2 = cam.rays_at(j + off[0], i + off[1])
        np.testing.assert_array_equal(d, d2)
        np.testing.assert_array_equal(o, o2)
    px, py = np.array([-0.7, 4.2, 10.3]), np.array([8.9, 3.3, -1.2])
    _, d = cam.rays_at(px, py)
    np.testing.assert_allclose(cam.project(np.asarray(cam.eye) + 2.0 * d), np.stack([px, py], -1),
                               atol=1e-4)
