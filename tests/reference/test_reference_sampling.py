"""Estimator properties of `reference`: χ² of the environment sampler against its pdf, MIS vs
BRDF-only vs env-only agreement (unbiasedness) and bit-determinism (seed, workers, passes)."""

import numpy as np
import pytest
from scipy.stats import chi2

from reference_testlib import assert_estimators_agree
from sgpipe.io import read_exr
from sgpipe.reference import EnvSampler, render_reference_result
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject

DATA = __import__("pathlib").Path(__file__).resolve().parents[2] / "data_samples"


class Phong:
    """Normalised Phong lobe about the mirror direction (test-local, exact sampling)."""

    def __init__(self, ks, n, kd=0.0):
        self.ks, self.n, self.kd = float(ks), float(n), float(kd)

    def _lobe(self, o, i):
        r = np.stack([-o[:, 0], -o[:, 1], o[:, 2]], -1)
        return np.maximum(np.sum(r * i, axis=1), 0.0) ** self.n, r

    def eval(self, o, i):
        c, _ = self._lobe(o, i)
        f = self.kd / np.pi + self.ks * (self.n + 2) / (2 * np.pi) * c
        return np.repeat(np.where((o[:, 2] > 0) & (i[:, 2] > 0), f, 0.0)[:, None], 3, 1)

    def pdf(self, o, i):
        c, _ = self._lobe(o, i)
        return 0.5 * (self.n + 1) / (2 * np.pi) * c + 0.5 * np.maximum(i[:, 2], 0) / np.pi

    def sample(self, o, u1, u2):
        spec = u1 < 0.5
        uu = np.where(spec, 2 * u1, 2 * u1 - 1)
        ct = np.where(spec, uu ** (1 / (self.n + 1)), np.sqrt(1 - uu))
        st = np.sqrt(np.maximum(0, 1 - ct * ct))
        loc = np.stack([st * np.cos(2 * np.pi * u2), st * np.sin(2 * np.pi * u2), ct], -1)
        _, r = self._lobe(o, o)
        a = np.where(np.abs(r[:, :1]) > 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
        t = np.cross(a, r)
        t /= np.linalg.norm(t, axis=1, keepdims=True)
        b = np.cross(r, t)
        i = np.where(spec[:, None], loc[:, :1] * t + loc[:, 1:2] * b + loc[:, 2:] * r, loc)
        return i, self.pdf(o, i)


# --- χ² of the environment importance sampler -----------------------------------------------
def _chi2_env(env_img, sub_theta, sub_phi, n, seed, merge_rows=1, merge_cols=1):
    """χ² p-value of EnvSampler samples over bins that split texels (sub_*) or merge them."""
    s = EnvSampler(env_img)
    h, w = s.shape
    rng = np.random.default_rng(seed)
    dirs, pdf, rad = s.sample(rng.random(n), rng.random(n))
    # pdf and radiance are those of the texel the lookup finds (consistency of sample/lookup)
    rad2, pdf2 = s.lookup(dirs)
    assert np.mean(np.isclose(pdf, pdf2, rtol=1e-12)) > 0.999
    assert np.mean(np.all(np.isclose(rad, rad2), axis=1)) > 0.999
    # bins uniform in θ and φ: texel rows/cols split into sub_* parts or merged by merge_*
    bh, bw = h * sub_theta // merge_rows, w * sub_phi // merge_cols
    theta = np.arccos(np.clip(dirs[:, 1], -1, 1))
    phi = np.mod(np.arctan2(dirs[:, 0], -dirs[:, 2]), 2 * np.pi)
    bi = np.minimum((theta / np.pi * bh).astype(int), bh - 1)
    bj = np.minimum((phi / (2 * np.pi) * bw).astype(int), bw - 1)
    counts = np.bincount(bi * bw + bj, minlength=bh * bw).astype(float)
    # expected: ∫_bin p dω with p = Y_texel / Z, Z = Σ Y Ω (exact per-texel solid angles)
    fh, fw = h * sub_theta, w * sub_phi
    ce = np.cos(np.pi * np.arange(fh + 1) / fh)
    omega_fine = np.repeat(((2 * np.pi / fw) * (ce[:-1] - ce[1:]))[:, None], fw, 1)
    lum_fine = np.repeat(np.repeat(s.lum, sub_theta, 0), sub_phi, 1)
    z = np.sum(s.lum * np.repeat(((2 * np.pi / w) * (np.cos(np.pi * np.arange(h) / h)
                                  - np.cos(np.pi * np.arange(1, h + 1) / h)))[:, None], w, 1))
    p_fine = lum_fine * omega_fine / z
    p_bin = p_fine.reshape(bh, merge_rows, bw, merge_cols).sum((1, 3)).ravel()
    assert abs(p_bin.sum() - 1) < 1e-9
    assert counts[p_bin == 0].sum() == 0  # never samples where the pdf is zero
    exp = p_bin * n
    # pool low-expectation bins (pbrt/Mitsuba practice): expected >= 5 per cell
    order = np.argsort(exp)
    small = order[np.cumsum(exp[order]) < 5 * max(1, (exp < 5).sum())]
    keep = np.setdiff1d(np.flatnonzero(exp >= 5), small)
    obs = np.append(counts[keep], counts.sum() - counts[keep].sum())
    ex = np.append(exp[keep], n - exp[keep].sum())
    obs, ex = obs[ex > 0], ex[ex > 0]
    stat = np.sum((obs - ex) ** 2 / ex)
    return chi2.sf(stat, len(ex) - 1)


def test_env_sampler_chi2_within_texels():
    """Random 8×16 map with dark texels; bins split every texel 3×2 in (θ, φ)."""
    rng = np.random.default_rng(5)
    img = rng.uniform(0, 1, (8, 16, 3)) ** 3
    img[2, 3] = 0.0
    img[5, :4] = 0.0
    img[1, 7] = 40.0
    p = _chi2_env(img, 3, 2, 200_000, seed=1)
    assert p > 1e-3, p


@pytest.mark.parametrize("name", ["studio.exr", "sky_sun.exr"])
def test_env_sampler_chi2_sample_maps(name):
    """The sample environments, bins of 8×8 texels."""
    p = _chi2_env(read_exr(DATA / name), 1, 1, 300_000, seed=2, merge_rows=8, merge_cols=8)
    assert p > 1e-3, p


def test_env_pdf_is_normalised_and_proportional_to_luminance():
    img = np.random.default_rng(0).uniform(0, 2, (6, 12, 3))
    s = EnvSampler(img)
    h, w = s.shape
    ce = np.cos(np.pi * np.arange(h + 1) / h)
    omega = np.repeat(((2 * np.pi / w) * (ce[:-1] - ce[1:]))[:, None], w, 1)
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    th, ph = np.pi * v[:, None], 2 * np.pi * u[None, :]
    d = np.stack(np.broadcast_arrays(np.sin(th) * np.sin(ph), np.cos(th),
                                     -np.sin(th) * np.cos(ph)), -1).reshape(-1, 3)
    rad, pdf = s.lookup(d)
    np.testing.assert_allclose(rad.reshape(h, w, 3), img, rtol=0, atol=0)
    assert np.sum(pdf.reshape(h, w) * omega) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(pdf.reshape(h, w) / s.lum, 1.0 / s.z, rtol=1e-12)


# --- MIS unbiasedness ------------------------------------------------------------------------
def _strategies(objs, mats, env, cam, spp, seed):
    return {s: render_reference_result(objs, cam, env, materials=mats, spp=spp, seed=seed,
                                       workers=1, strategy=s)
            for s in ("mis", "brdf", "env")}


def test_mis_brdf_env_agree_glossy_phong_studio():
    cam = Camera(eye=(0, 0, 4), target=(0, 0, 0), fov_deg=30, width=16, height=16)
    env = read_exr(DATA / "studio.exr")
    objs = [TraceObject.sphere("s", (0, 0, 0), 1.0)]
    res = _strategies(objs, [Phong(0.6, 40, kd=0.3)], env, cam, spp=96, seed=7)
    assert_estimators_agree(res)
    # MIS should not be worse than the worse single technique
    v = {k: np.mean(r.stderr[r.hit] ** 2) for k, r in res.items()}
    assert v["mis"] < max(v["brdf"], v["env"]), v


# --- determinism -----------------------------------------------------------------------------
def _small_scene():
    cam = Camera(eye=(0, 1.5, 3.5), target=(0, 0.4, 0), fov_deg=45, width=40, height=36)
    v = np.array([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], float)
    objs = [TraceObject.mesh("floor", v, [[0, 2, 1], [0, 3, 2]]),
            TraceObject.sphere("ball", (0, 0.6, 0), 0.6)]
    env = read_exr(DATA / "sky_sun.exr")
    return objs, cam, env


def test_seed_determinism_and_progressive_checkpoints():
    objs, cam, env = _small_scene()
    mats = [Phong(0.3, 10, kd=0.5), Phong(0.8, 200, kd=0.1)]
    kw = dict(materials=mats, seed=4, workers=1)
    a = render_reference_result(objs, cam, env, spp=12, progressive_every=4, **kw)
    b = render_reference_result(objs, cam, env, spp=12, **kw)
    c = render_reference_result(objs, cam, env, spp=4, **kw)
    assert np.array_equal(a.image, b.image)                    # passes do not matter
    assert [k for k, _ in a.checkpoints] == [4, 8, 12]
    assert np.array_equal(a.checkpoints[0][1], c.image)       # checkpoint 4 == a 4-spp render
    assert np.array_equal(a.checkpoints[-1][1], a.image)
    d = render_reference_result(objs, cam, env, spp=12, materials=mats, seed=5, workers=1)
    assert not np.array_equal(a.image, d.image)
    # pixel-centre rays: the background is not random
    e, f = (render_reference_result(objs, cam, env, spp=2, materials=mats, seed=s, workers=1,
                                    pixel_filter="center") for s in (4, 5))
    assert not np.array_equal(e.image, f.image)
    assert np.array_equal(e.image[~e.hit], f.image[~f.hit])


def test_worker_count_does_not_change_the_image():
    objs, cam, env = _small_scene()
    mats = [Phong(0.3, 10, kd=0.5), Phong(0.8, 200, kd=0.1)]
    one = render_reference_result(objs, cam, env, materials=mats, spp=6, seed=9, workers=1)
    two = render_reference_result(objs, cam, env, materials=mats, spp=6, seed=9, workers=2)
    assert np.array_equal(one.image, two.image)
    assert np.array_equal(one.stderr, two.stderr)


def test_counter_rng_is_uniform_and_decorrelated():
    """The hashed uniforms u(seed, pixel, sample, dim): 1-D and 2-D χ² uniformity, no
    correlation between dimensions, neighbouring pixels or seeds."""
    from sgpipe.reference import _sampling_jit as jit
    pid = np.arange(2000, dtype=np.int64)
    u = jit.uniforms(np.uint64(7), pid, 0, 32, 4)          # (2000, 32, 4)
    v = jit.uniforms(np.uint64(8), pid, 0, 32, 4)
    assert u.min() >= 0.0 and u.max() < 1.0
    flat = u.reshape(-1, 4)
    for d in range(4):
        c = np.bincount((flat[:, d] * 100).astype(int), minlength=100)
        assert chi2.sf(np.sum((c - len(flat) / 100) ** 2 / (len(flat) / 100)), 99) > 1e-3
    c2 = np.bincount((flat[:, 0] * 16).astype(int) * 16 + (flat[:, 1] * 16).astype(int),
                     minlength=256)
    assert chi2.sf(np.sum((c2 - len(flat) / 256) ** 2 / (len(flat) / 256)), 255) > 1e-3
    lim = 5 / np.sqrt(flat.shape[0])                         # 5σ of a null correlation
    pairs = [(flat[:, 0], flat[:, 1]), (flat[:, 2], flat[:, 3]),
             (u[:-1, :, 0].ravel(), u[1:, :, 0].ravel()),    # neighbouring pixels
             (u[:, :-1, 0].ravel(), u[:, 1:, 0].ravel()),    # consecutive samples
             (u.ravel(), v.ravel())]                          # seeds
    for a, b in pairs:
        assert abs(np.corrcoef(a, b)[0, 1]) < lim
    # a sample's numbers do not depend on where its batch starts
    np.testing.assert_array_equal(jit.uniforms(np.uint64(7), pid[5:9], 10, 3, 4), u[5:9, 10:13])
