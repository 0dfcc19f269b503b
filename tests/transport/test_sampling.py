"""Transport sampling (Green06 eq 2) against brute-force quadrature, an occluder that removes
exactly half of the light directions, and the SH transfer against the clamped cosine's SH."""

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.core.sphere import tangent_frame
from sgpipe.transport.sampling import light_cube, vertex_transport, vertex_visibility
from sgpipe.transport.sh_transfer import clamped_cosine_sh, texel_basis, transfer_vector
from sgpipe.transport.views import view_set
from sgpipe.visibility.trace import build_scene

L = 1000.0


def slab_scene():
    """A half-plane at height 1 over world x ∈ [0, L]: from the origin (normal +Y) it occludes
    exactly the upper-hemisphere directions with ω_x > 0."""
    a, b, c, d = (0, 1, -L), (L, 1, -L), (L, 1, L), (0, 1, L)
    return build_scene(np.array([[a, b, c], [a, c, d]], float))


def frame(n):
    n = np.asarray(n, float) / np.linalg.norm(n)
    t, b = tangent_frame(n)
    return n, t, b


def quadrature(brdf, n, t, b, v, res=512):
    """∫ f_s(ω, v) max(n·ω, 0) dω by the midpoint rule in (cos θ, φ) of the local frame."""
    mu = (np.arange(res) + 0.5) / res
    phi = (np.arange(2 * res) + 0.5) / (2 * res) * 2 * np.pi
    s = np.sqrt(1 - mu[:, None] ** 2)
    loc = np.stack([s * np.cos(phi), s * np.sin(phi), np.broadcast_to(mu[:, None], (res, 2 * res))], -1)
    vl = np.array([v @ t, v @ b, v @ n])
    f = brdf.specular(vl, loc) * mu[:, None, None]
    return f.sum((0, 1)) * (1.0 / res) * (2 * np.pi / (2 * res))


@pytest.mark.parametrize("model,params", [
    ("ggx", {"alpha": 0.3, "ks": 1.0, "fresnel": "schlick", "f0": 0.5}),
    ("ward", {"alpha": 0.25, "ks": 0.7}),
])
def test_transport_integral_matches_quadrature(model, params):
    brdf = make_brdf(model, params)
    n, t, b = frame([0.3, 0.9, -0.2])
    cube = light_cube(32)
    views, _, _, _ = view_set()
    vis = vertex_visibility(None, np.zeros(3), n, cube.dirs, 0.0)
    T, active = vertex_transport(brdf, n, t, b, views, cube, vis)
    assert np.array_equal(active, views @ n > 0)
    assert not T[~active].any()
    for v in np.flatnonzero(active)[::7]:
        if views[v] @ n < 0.25:
            continue    # grazing views: the lobe is cut by the horizon texels, still checked below
        ref = quadrature(brdf, n, t, b, views[v])
        got = (T[v] * cube.omega[:, None]).sum(0)
        assert np.allclose(got, ref, rtol=0.01), (v, got, ref)


def test_occluder_halves_transport_exactly():
    brdf = make_brdf("ggx", {"alpha": 0.4, "ks": 1.0, "fresnel": "none"})
    n, t, b = frame([0, 1, 0])
    cube = light_cube(16)
    views, _, _, _ = view_set()
    # views in the plane x = 0 make T symmetric under x → −x; the slab removes ω_x > 0
    v = np.array([[0.0, np.cos(a), np.sin(a)] for a in (0.0, 0.4, -0.9)])
    free = vertex_visibility(None, np.zeros(3), n, cube.dirs, 1e-4)
    occ = vertex_visibility(slab_scene(), np.zeros(3), n, cube.dirs, 1e-4)
    assert np.array_equal(occ, free & (cube.dirs[:, 0] < 0))
    Tf, _ = vertex_transport(brdf, n, t, b, v, cube, free)
    To, _ = vertex_transport(brdf, n, t, b, v, cube, occ)
    If = (Tf * cube.omega[None, :, None]).sum(1)
    Io = (To * cube.omega[None, :, None]).sum(1)
    assert np.all(If > 0.1)
    assert np.allclose(Io, 0.5 * If, rtol=1e-10)


def test_unshadowed_transfer_is_clamped_cosine_sh():
    cube = light_cube(64)
    B = texel_basis(cube)
    for nvec in ([0, 1, 0], [0.3, -0.5, 0.8], [1, 0, 0]):
        n = np.asarray(nvec, float) / np.linalg.norm(nvec)
        vis = np.ones(len(cube.dirs), bool)
        got = transfer_vector(B, cube, n, vis)
        ref = clamped_cosine_sh(n)
        assert ref[0] == pytest.approx(np.sqrt(np.pi) / 2)          # π · Y_00
        assert np.max(np.abs(got - ref)) < 2e-3, np.max(np.abs(got - ref))
    # a shadow that is not symmetric moves odd bands: the slab halves only the constant term
    n = np.array([0.0, 1.0, 0.0])
    occ = vertex_visibility(slab_scene(), np.zeros(3), n, cube.dirs, 1e-4)
    t_occ = transfer_vector(B, cube, n, occ)
    t_free = transfer_vector(B, cube, n, vertex_visibility(None, np.zeros(3), n, cube.dirs, 0))
    assert t_occ[0] == pytest.approx(0.5 * t_free[0], rel=1e-12)
