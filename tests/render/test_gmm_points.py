"""`gmm` with the environment's point set (render.gmm_points): a map that is one bright texel is
shaded exactly as Σ α E vMF(p; μ, κ) (the MIP chain without the point is empty), Töral19's MIP
lookups of the whole map move it towards a coarse texel's centre, and the residual chain plus
the points hold the map's energy."""

import numpy as np
import pytest
from dataclasses import replace

from sgpipe.core.maps import cubemap_dir, cubemap_solid_angles, dir_to_cubemap
from sgpipe.core.maps import bordered_box_level, image_to_faces
from sgpipe.envmap.mip import build_cube_chain
from sgpipe.render.envdata import CubeChain, EnvData
from sgpipe.render.materials import Material, pack_materials
from sgpipe.render.records import KernelFlag
from sgpipe.render.renderer import Frame, ObjectShading, Renderer
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject, trace_gbuffer

pytestmark = pytest.mark.opencl

N = 32
KAPPA = 20.0
ALPHA = np.array([0.9, 0.6, 0.3])


def _point_env(face=4, i=20, j=13, radiance=(4e3, 2e3, 1e3)):
    """(EnvData of a cubemap that is one bright texel, its point set holding that texel the way
    the envmap stage keeps it (texel centre, E = L·Ω), the point, its energy)."""
    cube = np.zeros((6, N, N, 3))
    cube[face, i, j] = radiance
    p = cubemap_dir(face, (j + 0.5) / N, (i + 0.5) / N)
    E = np.asarray(radiance) * cubemap_solid_angles(N)[face, i, j]
    env = replace(EnvData.constant(0.0, face_res=N),
                  mip=CubeChain.from_levels(build_cube_chain(cube).levels),
                  raw=CubeChain.from_levels([bordered_box_level(np.zeros_like(cube))]),
                  point_dirs=p[None].astype(np.float32), point_energy=E[None].astype(np.float32))
    return env, p, E


def _mirror_material():
    """One lobe per view at the view's mirror direction (α, κ fixed), 4 views in θ."""
    nt = 4
    theta = np.radians(np.linspace(0, 85, nt))
    m = Material("g", ks=np.ones(3), g_scale=1.0, diffuse=2, fresnel=0, shadowing=1)
    m.gmm = {"view_theta": theta, "view_phi": np.zeros(1),
             "alpha": np.broadcast_to(ALPHA, (nt, 1, 3)).copy(), "kappa": np.full((nt, 1), KAPPA),
             "mu_theta": theta[:, None].copy(), "mu_phi": np.zeros((nt, 1)),
             "includes_diffuse": np.int32(0), "coherent": np.int32(0)}
    return m


@pytest.fixture(scope="module")
def shaded():
    env, p, E = _point_env()
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), width=48, height=48, fov_deg=30)
    o, d = cam.rays()
    fr = Frame.from_gbuffer(trace_gbuffer([TraceObject.sphere("s", (0, 0, 0), 1.0)], o, d))
    n, v = fr.normal[:, :3].astype(float), fr.view[:, :3].astype(float)
    refl = 2 * np.sum(n * v, 1)[:, None] * n - v
    out = {}
    for pts in (True, False):
        # rotate: the lobe is carried rigidly to the pixel's mirror direction, κ unchanged
        r = Renderer(env=env, materials=pack_materials([_mirror_material()]),
                     objects=[ObjectShading(0)], gmm_carry="rotate", gmm_points=pts)
        out[pts] = r.shade("gmm", fr, flags=KernelFlag.NO_VISIBILITY).astype(float)
    vmf = KAPPA / (2 * np.pi * (1 - np.exp(-2 * KAPPA))) * np.exp(KAPPA * (refl @ p - 1))
    return out, ALPHA * E * vmf[:, None], refl, p


def test_point_environment_is_the_analytic_vmf_sum(shaded):
    """With points: every pixel is α E vMF(p; r, κ) (the residual chain is empty)."""
    out, exact, _, _ = shaded
    assert exact.max() > 10 * exact.mean()          # the highlight is on the sphere
    np.testing.assert_allclose(out[True], exact, rtol=2e-4, atol=1e-6 * exact.max())


def test_without_points_the_highlight_moves_to_a_coarse_texel_centre(shaded):
    """Töral19's box chain: the lobe (σ = 1/√κ ≈ 4 finest texels) reads levels whose texel
    holds the point somewhere off its centre; the highlight's centroid moves towards it."""
    out, exact, refl, p = shaded
    err = np.linalg.norm(out[False] - exact) / np.linalg.norm(exact)
    assert err > 0.1
    # the same energy reaches the sphere's highlight (the box chain conserves it) …
    sel = refl @ p > np.cos(4 / np.sqrt(KAPPA))
    lum = lambda im: im[sel].sum(1)                  # noqa: E731
    cen = lambda w: (w[:, None] * refl[sel]).sum(0) / np.linalg.norm((w[:, None] * refl[sel]).sum(0))  # noqa: E731
    c_exact, c_box = cen(lum(exact)), cen(lum(out[False]))
    c_pts = cen(lum(out[True]))
    # … but centred elsewhere: towards the centre of the level-2 (8², texel ≈ σ) texel of p
    face, s, t = dir_to_cubemap(p)
    n2 = N // 4
    centre = cubemap_dir(face, (np.floor(s * n2) + 0.5) / n2, (np.floor(t * n2) + 0.5) / n2)
    ang = lambda a, b: np.arccos(np.clip(a @ b, -1, 1))      # noqa: E731
    assert ang(c_pts, c_exact) < 1e-3
    assert ang(c_box, c_exact) > 0.1 / np.sqrt(KAPPA)
    assert ang(c_box, centre) < ang(c_exact, centre)


def test_residual_chain_and_points_hold_the_maps_energy():
    """A sky with a sun through the envmap stage's pyramid (point set + raw residual): every
    level of the residual MIP chain plus Σ E_p integrates to ∫L dω of the whole map's chain."""
    from sgpipe.envmap.pyramid import PyramidSettings, build_pyramid
    f, s, t = np.meshgrid(np.arange(6), (np.arange(N) + 0.5) / N, (np.arange(N) + 0.5) / N,
                          indexing="ij")
    d = cubemap_dir(f, t, s)
    cube = np.stack([0.3 + 0.2 * d[..., 1], 0.4 + 0.1 * d[..., 0], 0.6 + 0.0 * d[..., 2]], -1)
    cube[4, 9, 21] = (5e4, 4e4, 3e4)                 # a sun of two texels
    cube[4, 9, 22] = (2e4, 1.6e4, 1.2e4)
    pyr = build_pyramid(cube, PyramidSettings())
    assert len(pyr.point_dirs) == 2
    env = replace(EnvData.constant(0.0, face_res=N),
                  mip=CubeChain.from_levels(build_cube_chain(cube).levels),
                  raw=CubeChain.from_levels([pyr.raw]),
                  point_dirs=pyr.point_dirs.astype(np.float32),
                  point_energy=pyr.point_energy.astype(np.float32))
    res = env.residual_mip()
    assert res is not env.mip and list(res.res) == list(env.mip.res)
    pts = pyr.point_energy.sum(0)

    def energy(chain, lev):
        n = int(chain.res[lev])
        faces = image_to_faces(chain.level(lev))[:, 1:-1, 1:-1].astype(float)
        return (faces * cubemap_solid_angles(n)[..., None]).sum((0, 1, 2))

    total = energy(env.mip, 0)
    assert pts.sum() > 0.5 * total.sum()              # the sun dominates the map
    for lev in range(len(res.res)):
        np.testing.assert_allclose(energy(res, lev) + pts, total, rtol=1e-5)
    # the residual holds no sun: its brightest texel is sky
    assert image_to_faces(res.level(0))[:, 1:-1, 1:-1].max() < 1.0
    # and gmm_points off (or no points) keeps the whole map's chain
    assert replace(env, point_dirs=np.zeros((0, 3), np.float32)).residual_mip() is env.mip


def test_each_point_is_shadowed_at_its_own_direction():
    """With visibility on (no SSDF: the tangent plane is the occluder), a point below a pixel's
    horizon adds nothing there even where the lobe's axis is above it and reaches the point,
    and a point above the horizon adds its whole vMF sum. (A rim-hidden sun in a bowl lit
    gmm's inner wall through the lobe's visibility: 22.6 dB on the fidelity corpus.)"""
    from sgpipe.core.maps import cubemap_dir as cdir
    back = next(f for f in range(6) if cdir(f, 0.5, 0.5)[2] < -0.99)
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), width=96, height=96, fov_deg=30)
    o, d = cam.rays()
    fr = Frame.from_gbuffer(trace_gbuffer([TraceObject.sphere("s", (0, 0, 0), 1.0)], o, d))
    n, v = fr.normal[:, :3].astype(float), fr.view[:, :3].astype(float)
    refl = 2 * np.sum(n * v, 1)[:, None] * n - v
    for env, p, E in (_point_env(face=back, i=N // 2, j=N // 2), _point_env()):
        r = Renderer(env=env, materials=pack_materials([_mirror_material()]),
                     objects=[ObjectShading(0)], gmm_carry="rotate", gmm_points=True)
        out = r.shade("gmm", fr).astype(float)
        vmf = KAPPA / (2 * np.pi * (1 - np.exp(-2 * KAPPA))) * np.exp(KAPPA * (refl @ p - 1))
        exact = ALPHA * E * vmf[:, None]
        npl = n @ p
        if p[2] < 0:      # behind the sphere: the silhouette's lobes reach it, below horizon
            behind = (npl < -0.02) & (vmf > 0.05 * vmf.max())
            assert behind.sum() > 50
            assert out[behind].max() < 1e-6 * exact.max()
        else:             # in front: every pixel facing it gets its whole vMF sum, as
            lit = npl > 0.05                       # unshadowed (lobes near the horizon too)
            assert lit.sum() > 1000
            free = r.shade("gmm", fr, flags=KernelFlag.NO_VISIBILITY).astype(float)
            np.testing.assert_allclose(out[lit], free[lit], rtol=1e-4,
                                       atol=1e-7 * exact.max())
