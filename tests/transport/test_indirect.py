"""Indirect transport (Green06 §4.1 eq 5's T^IG, and the interreflected SH transfer): zero for a
convex object, the analytic answer for a surface facing a Lambert floor, and bounded gains for a
sphere on a floor."""

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.core.sh import sh_eval
from sgpipe.core.sphere import tangent_frame
from sgpipe.io.mesh import build_mesh, sphere_mesh
from sgpipe.transport.sampling import (PathScene, cube_texel, light_cube, vertex_transport,
                                       vertex_indirect_transport, vertex_visibility)
from sgpipe.transport.sh_transfer import (clamped_cosine_sh, interreflected_transfer,
                                          transfer_vector, texel_basis)
from sgpipe.transport.views import view_set
from sgpipe.visibility.trace import build_scene

GLOSSY = ("ggx", {"alpha": 0.2, "ks": 0.8, "kd": 0.1, "fresnel": "none"})
RHO = np.array([0.7, 0.5, 0.3])
OFFSET = 1e-4


def _quad(name, half, y, normal_up=True, material=None):
    p = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]])
    f = np.array([[0, 2, 1], [0, 3, 2]]) if normal_up else np.array([[0, 1, 2], [0, 2, 3]])
    return build_mesh(p, f, name=name, material=material or name)


def _ball(subdiv=2, center=(0, 0, 0), radius=1.0):
    p, f, n = sphere_mesh(radius, subdiv)
    return build_mesh(p + np.asarray(center), f, normals=n, name="ball", material="ball")


def _scene(geoms, mats):
    return PathScene.from_geometry(geoms, mats), build_scene(
        np.concatenate([g.triangles for g in geoms]).astype(np.float32))


def test_cube_texel_inverts_the_texel_directions():
    cube = light_cube(8)
    assert np.array_equal(cube_texel(cube, cube.dirs), np.arange(len(cube.dirs)))


def test_a_convex_object_has_no_indirect_transport():
    """A lone icosphere never sees itself: T^IG and the indirect SH transfer are exactly 0."""
    g = _ball()
    scene, tri = _scene([g], [GLOSSY])
    brdf = make_brdf(*GLOSSY)
    cube = light_cube(8)
    views = view_set()[0]
    rng = np.random.default_rng(0)
    for v in range(0, len(g.positions), 17):
        x, n, t, b = g.positions[v], g.normals[v], g.tangents[v], g.bitangents[v]
        active = views @ n > 0.02
        T = vertex_indirect_transport(scene, brdf, x, n, t, b, views, active, cube, paths=16,
                                      bounces=3, offset=OFFSET, rng=rng)
        assert not T.any()
        vis = vertex_visibility(tri, x, n, cube.dirs, OFFSET)
        t_ind = interreflected_transfer(scene, cube, x, n, vis, paths=2, bounces=3,
                                        offset=OFFSET, rng=rng)
        assert not t_ind.any()
        # and its shadowed transfer is the clamped cosine's SH (no self-shadowing either)
        t0 = transfer_vector(texel_basis(cube), cube, n, vis)
        np.testing.assert_allclose(t0, clamped_cosine_sh(n), atol=0.02)


def _facing_floor():
    """A small glossy quad at height 1 facing down (normal −Y) over a 400 × 400 Lambert floor of
    albedo RHO: what the quad sees below is the floor, whose radiance under a unit environment
    is exactly RHO after one bounce (the quad hides 1e-4 / π of the floor's sky)."""
    quad = _quad("quad", 0.005, 1.0, normal_up=False, material="quad")
    floor = _quad("floor", 200.0, 0.0, material="floor")
    return quad, floor, _scene([quad, floor], [GLOSSY, ("lambert", {"kd": RHO.tolist()})])


def test_indirect_glossy_transport_of_a_surface_facing_a_lambert_floor():
    """Σ_j T^IG_j Ω_j = RHO · a_s(v) (the specular lobe's directional albedo: every lobe
    direction meets the floor, which sends back RHO), spread like the floor's cosine over the
    upper hemisphere: mean direction (0, 2/3, 0)."""
    quad, _, (scene, _) = _facing_floor()
    brdf = make_brdf(*GLOSSY)
    x, n, t, b = np.zeros(3) + [0, 1, 0], np.array([0, -1.0, 0]), *tangent_frame(
        np.array([[0, -1.0, 0]]))
    t, b = t[0], b[0]
    cube = light_cube(8)
    views = view_set()[0]
    active = views @ n > 0.3
    T = vertex_indirect_transport(scene, brdf, x, n, t, b, views, active, cube, paths=4096,
                                  bounces=1, offset=OFFSET, rng=np.random.default_rng(1))
    assert not T[~active].any()
    assert not T[:, cube.dirs[:, 1] < 0].any()       # only the sky side, where floor paths go
    for v in np.flatnonzero(active)[::5]:
        o = np.array([views[v] @ t, views[v] @ b, views[v] @ n])
        a_s = brdf.albedo(o, n=128, lobe="specular")
        got = (T[v] * cube.omega[:, None]).sum(0)
        np.testing.assert_allclose(got, RHO * a_s, rtol=0.03)
        mean_dir = (T[v, :, 1] * cube.omega) @ cube.dirs / got[1]
        np.testing.assert_allclose(mean_dir, [0, 2 / 3, 0], atol=0.03)
    # two bounces add only what the floor's paths bring back from the tiny quad
    T2 = vertex_indirect_transport(scene, brdf, x, n, t, b, views, active, cube, paths=4096,
                                   bounces=2, offset=OFFSET, rng=np.random.default_rng(1))
    np.testing.assert_allclose((T2 * cube.omega[None, :, None]).sum((0, 1)),
                               (T * cube.omega[None, :, None]).sum((0, 1)), rtol=1e-3)


def test_interreflected_transfer_of_a_surface_facing_a_lambert_floor():
    """The floor fills the quad's hemisphere with radiance RHO × (the floor's irradiance)/π,
    so the indirect transfer is RHO × the clamped cosine's SH about +Y (the floor's unshadowed
    transfer), while the shadowed transfer is (nearly) zero."""
    quad, _, (scene, tri) = _facing_floor()
    cube = light_cube(16)
    x, n = np.array([0, 1.0, 0]), np.array([0, -1.0, 0])
    vis = vertex_visibility(tri, x, n, cube.dirs, OFFSET)
    t0 = transfer_vector(texel_basis(cube), cube, n, vis)
    assert np.abs(t0).max() < 1e-2
    t_ind = interreflected_transfer(scene, cube, x, n, vis, paths=128, bounces=1,
                                    offset=OFFSET, rng=np.random.default_rng(2))
    want = clamped_cosine_sh(np.array([0, 1.0, 0]))[:, None] * RHO
    # 98 304 escaping paths: the 25 coefficients' sampling noise is about 1.2 % of the norm
    assert np.linalg.norm(t_ind - want) / np.linalg.norm(want) < 0.025
    np.testing.assert_allclose(t_ind[0], want[0], rtol=0.01)


@pytest.mark.parametrize("ball", [("lambert", {"kd": 0.6}), GLOSSY])
def test_sphere_on_floor_gains_indirect_energy_bounded_by_albedo(ball):
    """Floor vertices around a ball's foot: under a unit environment the indirect irradiance
    √(4π)·t_00 is > 0 and at most the neighbours' albedo bound a_max × (π − direct irradiance)
    (no surface sends back more than a_max times a unit sky); the ball's lower vertices gain
    indirect glossy transport of the floor, bounded the same way by RHO × a_s."""
    ballg = _ball(2, center=(0, 1.05, 0))
    floor = build_mesh(*_grid(8, 2.0), name="floor", material="floor")
    scene, tri = _scene([ballg, floor], [ball, ("lambert", {"kd": RHO.tolist()})])
    cube = light_cube(8)
    basis = texel_basis(cube)
    rng = np.random.default_rng(3)
    a_max = max(RHO.max(), sum(np.max(ball[1].get(k, 0.0)) for k in ("kd", "ks")))
    near = np.flatnonzero(np.linalg.norm(floor.positions[:, [0, 2]], axis=1) < 0.8)
    assert len(near) >= 5
    for v in near:
        x, n = floor.positions[v], floor.normals[v]
        vis = vertex_visibility(tri, x, n, cube.dirs, OFFSET)
        e0 = np.sqrt(4 * np.pi) * transfer_vector(basis, cube, n, vis)[0]
        e_ind = np.sqrt(4 * np.pi) * interreflected_transfer(
            scene, cube, x, n, vis, paths=8, bounces=2, offset=OFFSET, rng=rng)[0]
        assert np.all(e_ind > 0.01 * (np.pi - e0)), (v, e_ind, e0)
        assert np.all(e_ind <= a_max * (np.pi - e0) + 1e-9), (v, e_ind, e0)
    brdf = make_brdf(*GLOSSY)
    views = view_set()[0]
    low = np.flatnonzero(ballg.normals[:, 1] < -0.5)
    gained = 0
    for v in low[::4]:
        x, n, t, b = (ballg.positions[v], ballg.normals[v], ballg.tangents[v],
                      ballg.bitangents[v])
        active = views @ n > 0.1
        T = vertex_indirect_transport(scene, brdf, x, n, t, b, views, active, cube, paths=256,
                                      bounces=2, offset=OFFSET, rng=rng)
        for w in np.flatnonzero(active):
            o = np.array([views[w] @ t, views[w] @ b, views[w] @ n])
            got = (T[w] * cube.omega[:, None]).sum(0)
            bound = a_max * brdf.albedo(o, n=32, lobe="specular")
            assert np.all(got <= 1.1 * bound + 1e-6), (v, w, got, bound)  # 10 %: 256 paths
        gained += T.any()
    assert gained == len(low[::4])


def _grid(k, half):
    """A (2k+1)² vertex floor grid of half-size `half` at y = 0, normal +Y."""
    xs = np.linspace(-half, half, 2 * k + 1)
    gx, gz = np.meshgrid(xs, xs)
    p = np.stack([gx.ravel(), np.zeros(gx.size), gz.ravel()], -1)
    m = 2 * k + 1
    f = []
    for i in range(m - 1):
        for j in range(m - 1):
            a, b, c, d = i * m + j, i * m + j + 1, (i + 1) * m + j + 1, (i + 1) * m + j
            f += [[a, c, b], [a, d, c]]
    return p, np.array(f)
