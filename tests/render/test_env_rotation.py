"""render.environment_rotation: every method under a rotation R equals the same method under the
pre-rotated environment.

* Exact (quarter turns, every OpenCL method of the registry): the environment's cubemaps turned texel by
  texel (a quarter turn maps the bordered cube grid onto itself), its direction arrays turned,
  against the kernels' rotated lookups (cubemap.h `env_to_map`) — equal to float rounding.
* Rebuilt (the lat-long map rolled by W/4 columns, which is a quarter turn about +Y exactly, and
  the envmap stage run again on it): what the stage rebuilds equivariantly (Γ_L pyramid, point
  set, SH light) agrees to float rounding; the MIP chain's cube-corner texels and the SG light
  fit (a local optimum) are not equivariant in the stage itself, measured and bounded.
* Reference: the rotated sampler's lookups equal the rolled map's, its pdf integrates to 1
  and its samples pass a chi-square test against it; BRDF-sampled reference images are
  identical, MIS images agree within their standard errors.
* SH: rotating coefficients = projecting the rotated function.
* A bad key is one BadInput line naming render.environment_rotation.<key>, exit 2.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import yaml

from sg_testlib import latlong_dirs_and_weights
from sgpipe.config import load_config
from sgpipe.io import write_exr
from sgpipe.core.rotation import rotation_matrix
from sgpipe.render.envdata import CubeChain, EnvData, GammaChain

pytestmark = pytest.mark.opencl

H, W = 32, 64
ROLL_R = rotation_matrix([0, 1, 0], -90.0)     # np.roll(map, W // 4, axis=1) turns it by this
METHODS = tuple(__import__("sgpipe.render.methods", fromlist=["METHODS"]).METHODS)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _sky():
    """A sky with a horizon gradient, a brighter +X side and a sharp sun (the point set)."""
    d, _ = latlong_dirs_and_weights(H, W)
    sun = _unit(np.array([0.5, 0.75, 0.43]))
    base = (0.3 + 0.5 * np.clip(d[..., 1:2], 0, 1) * np.array([0.6, 0.8, 1.0])
            + 0.4 * np.clip(d[..., 0:1], 0, 1) * np.array([1.0, 0.7, 0.4]))
    blob = 12.0 * np.exp(30.0 * (d @ sun - 1.0))[..., None] * np.array([1.0, 0.9, 0.75])
    return (base + blob).astype(np.float32)


def _build_env(folder, image):
    from sgpipe.stages import envmap
    folder.mkdir(parents=True, exist_ok=True)
    write_exr(folder / "env.exr", image)
    (folder / "c.yaml").write_text(yaml.safe_dump(
        {"name": "rot", "envmap": {"environment": "env.exr", "cube_resolution": 16}}))
    envmap.run(load_config(folder / "c.yaml"), folder / "out")
    return folder / "out" / "envmap"


@pytest.fixture(scope="module")
def envs(tmp_path_factory):
    """(map A, EnvData of A, its SH light; EnvData of A rolled by W/4 columns rebuilt by the
    envmap stage, its SH light)."""
    from sgpipe.artifacts.envmap import read_light_sh
    root = tmp_path_factory.mktemp("envrot")
    sky = _sky()
    da = _build_env(root / "a", sky)
    db = _build_env(root / "b", np.roll(sky, W // 4, axis=1))
    sh = lambda d: np.asarray(read_light_sh(d)["coeffs"], np.float64)  # noqa: E731
    return sky, EnvData.load(da), sh(da), EnvData.load(db), sh(db)


# --- a quarter-turned environment, texel by texel ---------------------------------------------
_AXES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def _face_point(f, a, b):
    """Point on face f's plane at face coordinates a = 2s − 1, b = 2t − 1 (CONVENTIONS table)."""
    one = np.ones_like(a)
    return np.stack([(one, -b, -a), (-one, -b, a), (a, one, b), (a, -one, -b), (a, -b, one),
                     (-a, -b, -one)][f], -1)


def _face_st(f, p):
    """(s, t) of a point p on face f's plane (|major| = 1), the CONVENTIONS table inverted."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    sc, tc = [(-z, -y), (z, -y), (x, z), (x, -z), (x, -y), (-x, -y)][f]
    return 0.5 * (sc + 1), 0.5 * (tc + 1)


def _turn_level(img, border, R):
    """A bordered cube level (6w, w, ...) of the map turned by the quarter-turn R: texel d' takes
    the texel at Rᵀd' (face planes map onto face planes, the grid onto itself)."""
    w = img.shape[1]
    n = w - 2 * border
    c = 2 * (np.arange(w) - border + 0.5) / n - 1
    a, b = np.meshgrid(c, c)                     # a follows columns (s), b rows (t)
    out = np.empty_like(img)
    for g in range(6):
        f = int(np.argmax(_AXES @ (R.T @ _AXES[g])))
        s, t = _face_st(f, _face_point(g, a, b) @ R)
        col = np.rint(s * n + border - 0.5).astype(int)
        row = np.rint(t * n + border - 0.5).astype(int)
        assert np.allclose(s * n + border - 0.5, col) and col.min() >= 0 and col.max() < w
        out[g * w:(g + 1) * w] = img[f * w + row, col]
    return out


def _turn_chain(ch: CubeChain, R) -> CubeChain:
    return CubeChain.from_levels([_turn_level(ch.level(l), 1, R) for l in range(len(ch.res))])


def _turn_gamma(g: GammaChain, R) -> GammaChain:
    vals, slps = [], []
    for off, n in zip(g.offsets, g.res):
        w = int(n) + 4
        lev = g.texels[2 * int(off):2 * (int(off) + 6 * w * w)].reshape(6 * w, w, 2, 4)
        lev = _turn_level(lev, 2, R)
        vals.append(lev[..., 0, :3])
        slps.append(lev[..., 1, :3])
    return GammaChain.from_levels(vals, slps)


def _turned_env(env: EnvData, R) -> EnvData:
    """`env` turned by the quarter-turn R into new arrays (no `rotation`)."""
    f32 = lambda a: (np.asarray(a, np.float64) @ R.T).astype(np.float32)  # noqa: E731
    return EnvData(pyramid=_turn_chain(env.pyramid, R), lambdas=env.lambdas,
                   log_ratio=env.log_ratio, mean=env.mean, mip=_turn_chain(env.mip, R),
                   light_axes=f32(env.light_axes), light_lambda=env.light_lambda,
                   light_mu=env.light_mu, gamma=_turn_gamma(env.gamma, R),
                   point_dirs=f32(env.point_dirs), point_energy=env.point_energy,
                   raw=None if env.raw is None else _turn_chain(env.raw, R))


# --- every method on one frame --------------------------------------------------------------
def _scene():
    """A sphere's G-buffer, a Beckmann material with a diffuse part (sg lobes, exact NDF table
    for fis, a per-view vMF mixture for gmm), a normal-map pyramid, transport Gaussians."""
    from sgpipe.brdf import make_brdf
    from sgpipe.render.materials import Material
    from sgpipe.render.renderer import Frame
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import TraceObject, trace_gbuffer
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), width=20, height=20, fov_deg=30)
    gb = trace_gbuffer([TraceObject.sphere("s", (0, 0, 0), 1.0)], *cam.rays())
    fr = Frame.from_gbuffer(gb)
    P = len(fr.index)
    rng = np.random.default_rng(5)
    fr.tri = np.arange(P, dtype=np.int32)              # transport: one triangle per pixel
    fr.bary = rng.dirichlet(np.ones(3), size=P)[:, 1:].astype(np.float32)
    fr.duv = np.tile(np.float32([0.05, 0.0, 0.0, 0.05]), (P, 1))
    brdf = make_brdf("beckmann", {"alpha": 0.25, "ks": 0.7, "kd": [0.3, 0.25, 0.2],
                                  "fresnel": "none"})
    m = Material.from_brdf("m", brdf)
    m.tabulate_ndf(brdf)
    nt, K = 5, 3
    theta = np.radians(np.linspace(0, 85, nt))
    m.gmm = {"view_theta": theta, "view_phi": np.zeros(1),
             "alpha": rng.uniform(0.1, 0.3, (nt, K, 3)),
             "kappa": np.exp(rng.uniform(np.log(3.0), np.log(300.0), (nt, K))),
             "mu_theta": np.clip(theta[:, None] + rng.normal(0, 0.2, (nt, K)), 0, 1.5),
             "mu_phi": rng.uniform(-np.pi, np.pi, (nt, K)),
             "includes_diffuse": np.int32(0), "coherent": np.int32(0)}
    # transport: per pixel three vertices, random smooth Gaussian fields over the 92 views
    from sgpipe.transport.views import N_VIEWS
    X = 3 * P
    mu = _unit(rng.normal(size=(X, 1, 1, 3)) + 0.3 * rng.normal(size=(X, N_VIEWS, 1, 3)))
    tp = dict(mu=mu, sigma=rng.uniform(0.15, 0.8, (X, N_VIEWS, 1)),
              w=rng.uniform(0.1, 1.0, (X, N_VIEWS, 1, 3)), transfer=rng.normal(0, 0.3, (X, 25)),
              diffuse_rgb=np.array([0.2, 0.15, 0.1]), faces=np.arange(X).reshape(P, 3))
    normals = np.concatenate([rng.normal(0, 0.4, (16, 16, 2)), np.ones((16, 16, 1))], -1)
    return fr, m, tp, _unit(normals)


@pytest.fixture(scope="module")
def scene():
    return _scene()


def _render_all(env, light_sh, scene, rotation=None, methods=METHODS):
    """{method: (P, 3)} of the scene under `env` (turned by `rotation` as the render stage turns
    it: Renderer.rotate_environment and the transport SH)."""
    from sgpipe.normalmap.pyramid import mean_normal_pyramid
    from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid
    from sgpipe.render.materials import pack_materials
    from sgpipe.render.normalmap_data import (NormalMapData, NormalMapPyramid, attach_normalmaps,
                                              specular_sh_coeffs)
    from sgpipe.render.renderer import ObjectShading, Renderer
    from sgpipe.render.transport_data import transport_arrays, upload_transport
    fr, m, tp, normals = scene
    r = Renderer(env=env, materials=pack_materials([m]), objects=[ObjectShading(0)])
    r.rotate_environment(rotation)
    upload_transport(r, transport_arrays([tp], light_sh, rotation))
    p = fit_vmf_pyramid(normals, VMFSettings(lobes=2, kappa_max=1e4))
    pyr = NormalMapPyramid(p.alpha, p.alpha_r, [a.astype(np.float32)
                                                for a in mean_normal_pyramid(normals)])
    # ρ̂_l for vmf_han07's eq 26 (nm_sh reads them only with an SH pyramid, none here)
    rho = [specular_sh_coeffs("blinn_phong", 40.0, 8)]
    attach_normalmaps(r, NormalMapData.pack([pyr], [40.0], rho_hat=rho)
                      .with_environment(light_sh, True))
    return {method: r.shade(method, fr).astype(np.float64) for method in methods}


def _rel(a, b):
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_quarter_turn_texel_permutation_matches_the_rebuilt_pyramid(envs):
    """The test's own turned cubemaps are right: A's Γ_L levels and point set turned by the roll's
    quarter turn equal the levels the envmap stage builds from the rolled map (1e-5)."""
    _, A, _, B, _ = envs
    T = _turned_env(A, ROLL_R)
    for l in range(len(A.pyramid.res)):
        assert _rel(T.pyramid.level(l), B.pyramid.level(l)) < 1e-5, l
    assert _rel(T.gamma.texels, B.gamma.texels) < 1e-4
    order = lambda d: np.lexsort(np.round(d, 5).T)  # noqa: E731
    np.testing.assert_allclose(T.point_dirs[order(T.point_dirs)],
                               B.point_dirs[order(B.point_dirs)], atol=1e-6)


@pytest.fixture(scope="module")
def rolled(envs, scene):
    """Renders under the roll's quarter turn about +Y: A rotated, A's arrays turned, the
    rebuilt rolled map, A unrotated."""
    from sgpipe.render.transport_data import rotate_sh
    _, A, sha, B, shb = envs
    return dict(got=_render_all(A, sha, scene, rotation=ROLL_R),
                turned=_render_all(_turned_env(A, ROLL_R), rotate_sh(sha, ROLL_R), scene),
                rebuilt=_render_all(B, shb, scene),
                plain=_render_all(A, sha, scene, methods=("sg", "gmm", "vmf")))


def test_every_method_under_a_quarter_turn_equals_the_turned_environment(rolled):
    """Rotation R in the kernels (cubemap.h defines, host-turned point set and SG light axes,
    rotated SH) = no rotation with every array of the environment turned by R: every OpenCL
    method (the normal-map ones with their environment specular and nm_sh's SH light) within
    1e-4 of the frame's maximum (measured: sg 2e-5 — a few pixels on the sun's steep tails,
    where the B-spline's face coordinate s and its mirror 1 − s round differently —, the
    others ≤ 1.3e-7); the rotation does change the images (> 5 %). `gmm_toral19`'s dual
    paraboloid is derived from the turned cube here, not turned texel for texel (a turn about
    +Y is no permutation of its grid): tests/render/test_gmm_toral19.py turns it about +Z.
    `vmf_han07` neither: its 16 × 16 table of views (Han07 §8) is fixed to the map's frame, so
    a turn that moves the views off the table's nodes changes its interpolation (5 % here, the
    published method's own property); the +Z test below turns it by whole table cells."""
    for m in METHODS:
        if m in ("gmm_toral19", "vmf_han07"):
            continue
        assert _rel(rolled["got"][m], rolled["turned"][m]) < 1e-4, m
    for m, img in rolled["plain"].items():
        assert _rel(img, rolled["turned"][m]) > 0.05, m


def test_sg_gmm_fis_under_a_turn_that_cycles_the_axes(envs, scene):
    """120° about (1, 1, 1) cycles x → y → z: no face keeps its place or orientation. The three
    kinds of cube lookup (Γ_L B-spline + raw map: sg, also transport's; per-level bilinear with
    the lobe's solid angle: gmm; trilinear MIP: fis) = the turned arrays (1e-5; measured
    ≤ 6e-7)."""
    from sgpipe.render.transport_data import rotate_sh
    _, A, sh, _, _ = envs
    R = rotation_matrix([1, 1, 1], 120.0)
    np.testing.assert_array_equal(R, [[0, 0, 1], [1, 0, 0], [0, 1, 0]])
    got = _render_all(A, sh, scene, rotation=R, methods=("sg", "gmm", "fis"))
    want = _render_all(_turned_env(A, R), rotate_sh(sh, R), scene, methods=("sg", "gmm", "fis"))
    for m in got:
        assert _rel(got[m], want[m]) < 1e-5, (m, _rel(got[m], want[m]))


def test_vmf_han07_under_a_quarter_turn_about_z(envs, scene):
    """A quarter turn about +Z maps the cube's texels and vmf_han07's 16 × 16 table of views
    (φ in 22.5° cells) onto themselves: rotated = the turned arrays (1e-5), and the turn changes
    the image."""
    from sgpipe.render.transport_data import rotate_sh
    _, A, sh, _, _ = envs
    R = rotation_matrix([0, 0, 1], 90.0)
    got = _render_all(A, sh, scene, rotation=R, methods=("vmf_han07",))["vmf_han07"]
    want = _render_all(_turned_env(A, R), rotate_sh(sh, R), scene,
                       methods=("vmf_han07",))["vmf_han07"]
    plain = _render_all(A, sh, scene, methods=("vmf_han07",))["vmf_han07"]
    assert _rel(got, want) < 1e-5, _rel(got, want)
    assert _rel(plain, want) > 0.05


def test_every_method_against_the_rebuilt_rolled_environment(rolled):
    """Roll the lat-long map by W/4 columns (exactly a quarter turn about +Y) and rebuild the
    envmap stage: rendering A rotated = rendering the rebuilt map. `transport` reads what the
    stage rebuilds equivariantly (Γ_L pyramid, point set, SH): 1e-5 (measured 4e-7). The other
    differences are the stage's own, not the rotation's: its SG light fit lands in a slightly
    different local optimum (the diffuse part of sg and the normal-map methods: ≤ 7.7e-4
    measured over two skies; the fit's own irradiance error is ~1e-3) and its
    box MIP chain's cube-corner border texels take the first neighbour face in x, y, z order,
    which a turn reorders (gmm 4e-3, fis 9e-3 measured); the turned-array test above is exact
    for those. `gmm_toral19` is left out: its dual paraboloid, resampled from the turned cube
    and box-filtered on the paraboloid's grid, is not turn-invariant (9 % here, the published
    method's own property); its rotation is tested about +Z in test_gmm_toral19.py."""
    err = {m: _rel(rolled["got"][m], rolled["rebuilt"][m]) for m in METHODS
           if m not in ("gmm_toral19", "vmf_han07")}
    print("rotated vs rebuilt:", {m: f"{e:.1e}" for m, e in err.items()})
    assert err["transport"] < 1e-5, err
    assert max(e for m, e in err.items() if m not in ("gmm", "fis")) < 3e-3, err
    assert max(err[m] for m in ("gmm", "fis")) < 2e-2, err


def test_glossy_sg_against_the_rebuilt_rolled_environment(envs, scene):
    """sg with the diffuse part off reads only the Γ_L pyramid and the point set: rotated A =
    the rebuilt rolled map to 1e-4."""
    from sgpipe.render.materials import pack_materials
    from sgpipe.render.records import KernelFlag
    from sgpipe.render.renderer import ObjectShading, Renderer
    _, A, _, B, _ = envs
    fr, m, _, _ = scene
    out = []
    for env, rot in ((A, ROLL_R), (B, None)):
        r = Renderer(env=env, materials=pack_materials([m]), objects=[ObjectShading(0)])
        r.rotate_environment(rot)
        out.append(r.shade("sg", fr, flags=KernelFlag.NO_ENV_DIFFUSE).astype(np.float64))
    assert _rel(*out) < 1e-4, _rel(*out)


# --- the reference -----------------------------------------------------------------------------
def test_reference_sampler_rotated_lookups_equal_the_rolled_map(envs):
    """lookup (radiance and pdf) of the sampler turned by the roll's R = the rolled map's, at
    random directions (directions within 1e-9 of a texel edge skipped)."""
    from sgpipe.reference import EnvSampler
    sky = envs[0]
    a = EnvSampler(sky, rotation=ROLL_R)
    b = EnvSampler(np.roll(sky, W // 4, axis=1))
    d = _unit(np.random.default_rng(3).normal(size=(20000, 3)))
    (ra, pa), (rb, pb) = a.lookup(d), b.lookup(d)
    np.testing.assert_array_equal(ra, rb)
    np.testing.assert_allclose(pa, pb, rtol=1e-12)


def test_reference_sampler_pickles_with_its_rotation(envs):
    """The worker processes get the sampler pickled (image + rotation): same lookups after."""
    import pickle
    from sgpipe.reference import EnvSampler
    s = EnvSampler(envs[0], rotation=rotation_matrix([1, 0, 1], 25.0))
    t = pickle.loads(pickle.dumps(s))
    d = _unit(np.random.default_rng(4).normal(size=(1000, 3)))
    np.testing.assert_array_equal(t.rotation, s.rotation)
    np.testing.assert_array_equal(t.lookup(d)[0], s.lookup(d)[0])


def test_reference_sampler_pdf_integrates_to_one_and_matches_its_samples(envs):
    """A general rotation (37° about (0.3, 1, −0.4)): ∫ pdf dω = 1 (fine world lat-long
    quadrature, 1e-3); every sample's pdf and radiance are the lookup's at its direction; the
    samples' histogram over 8×16 world lat-long bins against ∫_bin pdf: chi-square p > 1e-3 —
    and the sampler turned the wrong way (Rᵀ) fails the same test."""
    from scipy.stats import chi2
    from sgpipe.core.maps import dir_to_latlong
    from sgpipe.reference import EnvSampler
    sky = envs[0]
    R = rotation_matrix([0.3, 1.0, -0.4], 37.0)
    s = EnvSampler(sky, rotation=R)
    d, om = latlong_dirs_and_weights(8 * 16, 16 * 16, ss=1)    # 128 × 256 world quadrature
    pdf = s.pdf(d.reshape(-1, 3)).reshape(om.shape)
    assert abs(float((pdf * om).sum()) - 1.0) < 1e-3
    # expected bin probabilities: 16 × 16 quadrature points per bin
    p_bin = (pdf * om).reshape(8, 16, 16, 16).sum((1, 3))
    rng = np.random.default_rng(11)
    n = 200_000
    u1, u2 = rng.random(n), rng.random(n)
    dirs, p, rad = s.sample(u1, u2)
    r2, p2 = s.lookup(dirs)
    np.testing.assert_allclose(p, p2, rtol=1e-12)
    np.testing.assert_array_equal(rad, r2)

    def chi2_p(dd):
        u, v = dir_to_latlong(dd)
        k = np.clip((v * 8).astype(int), 0, 7) * 16 + np.clip((u * 16).astype(int), 0, 15)
        obs = np.bincount(k, minlength=128)
        e = p_bin.reshape(-1) * n
        keep = e > 5
        x2 = float(((obs[keep] - e[keep]) ** 2 / e[keep]).sum())
        return chi2.sf(x2, keep.sum() - 1)

    assert chi2_p(dirs) > 1e-3
    wrong = EnvSampler(sky, rotation=R.T).sample(u1, u2)[0]
    assert chi2_p(wrong) < 1e-6


def _reference_pair(sky, strategy, spp, rotation=ROLL_R):
    from sgpipe.brdf import make_brdf
    from sgpipe.reference import render_reference_result
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import TraceObject
    cam = Camera(eye=(0, 0.3, 3.5), target=(0, 0, 0), width=16, height=16, fov_deg=40)
    brdf = make_brdf("beckmann", {"alpha": 0.15, "ks": 0.8, "kd": 0.2, "fresnel": "none"})
    kw = dict(materials=[brdf], spp=spp, seed=3, workers=1, strategy=strategy)
    obj = [TraceObject.sphere("s", (0, 0, 0), 1.0)]
    a = render_reference_result(obj, cam, sky, env_rotation=rotation, **kw)
    b = render_reference_result(obj, cam, np.roll(sky, W // 4, axis=1), **kw)
    return a, b


def test_reference_brdf_sampled_image_equals_the_rolled_map(envs):
    """BRDF sampling only reads the map through lookups (shading points and the background):
    the rotated reference image is the rolled map's to 1e-6."""
    a, b = _reference_pair(envs[0], "brdf", 4)
    np.testing.assert_allclose(a.image, b.image, rtol=1e-6, atol=1e-7)


def _z(a, b):
    """Per-pixel differences over their combined standard error (where it is > 0)."""
    s = np.sqrt(a.stderr.astype(float) ** 2 + b.stderr.astype(float) ** 2)
    ok = s > 0
    return (a.image - b.image)[ok] / s[ok]


def test_reference_mis_image_agrees_with_the_rolled_map_within_its_noise(envs):
    """MIS draws different environment samples from the two maps' tables (the BRDF halves are
    the same numbers, so the two images are positively correlated): the differences stay within
    their standard errors (RMS z < 1.2, mean z < 0.2; measured 0.36, 0.01), while the sampler
    turned the wrong way (Rᵀ) is off by many (RMS z > 3)."""
    z = _z(*_reference_pair(envs[0], "mis", 16))
    assert abs(z.mean()) < 0.2 and np.sqrt((z * z).mean()) < 1.2, (z.mean(), z.std())
    z = _z(*_reference_pair(envs[0], "mis", 16, rotation=ROLL_R.T))
    assert np.sqrt((z * z).mean()) > 3, np.sqrt((z * z).mean())


# --- SH ------------------------------------------------------------------------------------------
def test_sh_rotation_equals_projection_of_the_rotated_function(envs):
    """rotate_sh(c, R) = the projection of f(Rᵀω): for an SG lobe e^{8(ω·p − 1)} (not band
    limited) projected by a Gauss–Legendre × uniform-φ rule (48 × 96, converged to ~1e-13), at
    a general R (1e-9); the inverse rotation is far off; and the envmap stage's SH of the
    rolled map = A's SH turned by the roll (1e-5)."""
    from sgpipe.core.sh import sh_project
    from sgpipe.render.transport_data import rotate_sh
    R = rotation_matrix([0.3, 1.0, -0.4], 37.0)
    p = _unit(np.array([0.2, 0.5, 0.8]))
    z, wz = np.polynomial.legendre.leggauss(48)
    phi = 2 * np.pi * np.arange(96) / 96
    st = np.sqrt(1 - z * z)[:, None]
    d = np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), z[:, None]),
                 -1).reshape(-1, 3)
    om = np.repeat(wz * 2 * np.pi / 96, 96)
    f = lambda x: np.exp(8.0 * (x @ p - 1.0))  # noqa: E731
    c = sh_project(f(d), d, om, 4)
    c_rot = sh_project(f(d @ R), d, om, 4)          # f(Rᵀω)
    np.testing.assert_allclose(rotate_sh(c, R), c_rot, atol=1e-9 * np.abs(c).max())
    assert np.abs(rotate_sh(c, R.T) - c_rot).max() > 1e-2 * np.abs(c).max()
    _, _, sha, _, shb = envs
    np.testing.assert_allclose(rotate_sh(sha, ROLL_R), shb, atol=1e-5 * np.abs(shb).max())


# --- config --------------------------------------------------------------------------------------
@pytest.mark.parametrize("value,key", [
    ({"axis": [0, 0, 0], "angle_deg": 30}, "render.environment_rotation.axis"),
    ({"axis": [0, 1, 0], "angle_deg": 400}, "render.environment_rotation.angle_deg"),
    ({"axis": [0, 1], "angle_deg": 30}, "render.environment_rotation.axis"),
    ({"axis": [0, 1, 0], "deg": 30}, "render.environment_rotation.deg"),
    ({"axis": [0, 1, 0], "angle_deg": "ninety"}, "render.environment_rotation.angle_deg")])
def test_bad_rotation_names_the_key(tmp_path, value, key):
    from sgpipe.errors import BadInput
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(yaml.safe_dump({"name": "bad", "render": {"environment_rotation": value}}))
    with pytest.raises(BadInput) as e:
        load_config(cfg)
    assert key in e.value.one_line() and str(cfg) in e.value.one_line()


def test_bad_rotation_on_the_command_line_is_one_line_exit_2(tmp_path):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(yaml.safe_dump({"name": "bad", "render": {
        "environment_rotation": {"axis": [0, 0, 0], "angle_deg": 30}}}))
    p = subprocess.run([sys.executable, "-m", "sgpipe", "render", str(cfg), "--out",
                        str(tmp_path / "out")], capture_output=True, text=True)
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "render.environment_rotation.axis" in lines[0], p.stderr
    assert not (tmp_path / "out").exists()


def test_config_rotation_matrix():
    """The key's matrix: quarter turns exact, the identity for 0°, R·axis = axis, right-handed
    (90° about +Y takes +Z to +X)."""
    from sgpipe.config.sections.render import EnvironmentRotationSpec
    assert EnvironmentRotationSpec().matrix() is None
    R = EnvironmentRotationSpec(axis=(0.0, 2.0, 0.0), angle_deg=90.0).matrix()
    np.testing.assert_array_equal(R @ [0, 0, 1.0], [1.0, 0, 0])
    R = EnvironmentRotationSpec(axis=(1.0, 2.0, 3.0), angle_deg=33.0).matrix()
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(R @ np.array([1, 2, 3.0]), [1, 2, 3.0], atol=1e-14)


def test_render_stage_rotates_every_method_and_the_background(tmp_path):
    """`sgpipe render` with environment_rotation (a quarter turn about +Y, as a config key) =
    the same config on the map rolled by W/4 columns: background pixels identical, `sg` within
    the SG light fit's own difference (3e-3 of the maximum), the 16-spp reference within its
    noise."""
    from sgpipe.artifacts.render import read_gbuffer
    from sgpipe.io import read_exr
    from sgpipe.stages import envmap, fit, render
    sky = _sky()
    imgs = {}
    for name, image, rot in (("rot", sky, {"axis": [0, 1, 0], "angle_deg": -90}),
                             ("roll", np.roll(sky, W // 4, axis=1), None)):
        write_exr(tmp_path / f"{name}.exr", image)
        rs = {"camera": {"eye": [0, 0.3, 3.5], "target": [0, 0, 0], "fov_deg": 50,
                         "width": 16, "height": 16}, "methods": ["sg", "reference"], "spp": 16}
        if rot:
            rs["environment_rotation"] = rot
        (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump({
            "name": name, "seed": 1, "workers": 1,
            "scene": {"objects": [{"name": "ball", "sphere_radius": 1.0, "material": "m"}]},
            "fit": {"materials": [{"name": "m", "model": "beckmann",
                                   "params": {"alpha": 0.2, "ks": 0.7, "kd": 0.25,
                                              "fresnel": "none"}}]},
            "envmap": {"environment": f"{name}.exr", "cube_resolution": 16}, "render": rs}))
        cfg = load_config(tmp_path / f"{name}.yaml")
        out = tmp_path / f"out_{name}"
        for stage in (fit, envmap, render):
            stage.run(cfg, out)
        imgs[name] = {m: read_exr(out / "render" / f"{m}.exr")[..., :3].astype(np.float64)
                      for m in ("sg", "reference")}
        hit = read_gbuffer(out / "render").hit
    a, b = imgs["rot"], imgs["roll"]
    np.testing.assert_array_equal(a["sg"][~hit], b["sg"][~hit])
    assert _rel(a["sg"][hit], b["sg"][hit]) < 3e-3
    diff = (a["reference"] - b["reference"])[hit]
    assert np.abs(diff.mean()) < 0.02 * b["reference"][hit].mean()


def test_mitsuba_envmap_to_world_is_the_rotation():
    """validation: Mitsuba's envmap with to_world = envmap_to_world(R) returns the map at Rᵀω,
    the replica's value there (what the rotated scenes of `python -m validation` rely on)."""
    pytest.importorskip("mitsuba")
    from validation import conventions as cv
    from validation import import_mitsuba
    try:
        mi = import_mitsuba()
    except (ImportError, AttributeError) as e:
        pytest.skip(f"Mitsuba's llvm_ad_rgb variant unavailable: {e}")
    import drjit as dr
    rng = np.random.default_rng(0)
    data = rng.random((8, 16, 3)).astype(np.float32)
    R = rotation_matrix([0.3, 1.0, -0.4], 37.0)
    d = _unit(rng.normal(size=(500, 3)))
    vals = []
    for rot in (R, R.T):
        em = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(data),
                           "to_world": mi.ScalarTransform4f(cv.envmap_to_world(rot))})
        si = dr.zeros(mi.SurfaceInteraction3f, len(d))
        si.wi = mi.Vector3f(*(-d.T.astype(np.float32)))
        vals.append(np.stack([np.asarray(em.eval(si)[k], np.float64) for k in range(3)], -1))
    want = cv.mitsuba_envmap_eval(data, d @ R)
    np.testing.assert_allclose(vals[0], want, rtol=2e-4, atol=2e-5)
    assert np.abs(vals[1] - want).max() > 0.05
