"""EnvData: reads the envmap contract (sgpipe.artifacts.envmap); its bilinear cube fetch is the
envmap package's; ∂ln S/∂ln λ of core.sg."""
import numpy as np
import pytest

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import envmap as art
from sgpipe.core.sg import dln_sg_norm, sg_integral
from sgpipe.errors import BadInput
from sgpipe.render.envdata import CubeChain, EnvData, GammaChain

RNG = np.random.default_rng(11)


def _unit(n):
    d = RNG.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_dln_sg_norm_is_the_log_slope_of_the_sg_integral():
    lam = np.geomspace(1e-3, 300.0, 40)
    h = 1e-5
    num = (np.log(sg_integral(lam * np.exp(h), 1.0)) - np.log(sg_integral(lam * np.exp(-h), 1.0))
           ) / (2 * h)
    np.testing.assert_allclose(dln_sg_norm(lam), num, rtol=1e-6, atol=1e-9)
    assert dln_sg_norm(0.0) == 0.0 and dln_sg_norm(1e4) == -1.0


def test_chain_bilinear_matches_the_envmap_packages_fetch():
    from sgpipe.envmap._cube_jit import sample_bordered
    levels = [RNG.uniform(0, 1, art.strip_shape(n, 1)).astype(np.float32) for n in (6, 3)]
    chain = CubeChain.from_levels(levels)
    d = _unit(500)
    for l, img in enumerate(levels):
        np.testing.assert_array_equal(chain.level(l), img)
        ref = sample_bordered(img.astype(np.float64), img.shape[1] - 2, 1, d, False,
                              np.empty((len(d), 3)))
        np.testing.assert_allclose(chain.bilinear(l, d), ref, rtol=1e-12, atol=1e-12)


def _folder(tmp_path, with_coefs):
    res = [4, 2]
    lam = np.array([4.0, 2.0])

    def strips(b):
        return [RNG.uniform(0.5, 1.0, art.strip_shape(n, b)).astype(np.float32) for n in res]
    pyr = art.PyramidArtifacts(lambdas=lam, face_res=np.array(res), ratio=2.0,
                               mean=np.array([0.7, 0.7, 0.7]), samples=strips(1),
                               values=strips(2) if with_coefs else None,
                               slopes=strips(2) if with_coefs else None,
                               point_dirs=np.array([[0.0, 0.0, 1.0]]),
                               point_energy=np.array([[1.0, 2.0, 3.0]]))
    sink = FolderSink(tmp_path)
    art.write_pyramid(sink, pyr)
    art.write_mip(sink, [np.ones(art.strip_shape(n, 1), np.float32) for n in (4, 2, 1)],
                  [np.ones((n, 2 * n, 3), np.float32) for n in (4, 2, 1)], dp_b=1.0,
                  coverage=0.9)
    art.write_light_sg(sink, axes=[[0.0, 1.0, 0.0]], sharpness=[2.0], amplitude=[[1.0, 1, 1]],
                       irradiance_rel_err=[0.0] * 3, irradiance_rel_err_eq40=[0.0] * 3)
    return pyr


def test_load_packs_what_the_writer_stored(tmp_path):
    pyr = _folder(tmp_path, with_coefs=True)
    env = EnvData.load(tmp_path)
    ref = GammaChain.from_levels(pyr.values, pyr.slopes)
    np.testing.assert_array_equal(env.gamma.texels, ref.texels)
    np.testing.assert_array_equal(env.pyramid.level(1), pyr.samples[1])
    assert env.log_ratio == pytest.approx(np.log(2.0)) and env.mip_N == 4
    np.testing.assert_array_equal(env.point_energy, [[1.0, 2.0, 3.0]])
    np.testing.assert_array_equal(env.light_lambda, [2.0])


def test_load_without_coefficients_derives_the_accurate_chain(tmp_path):
    pyr = _folder(tmp_path, with_coefs=False)
    env = EnvData.load(tmp_path)
    ref = GammaChain.from_samples(pyr.samples, pyr.lambdas.astype(np.float32))
    np.testing.assert_array_equal(env.gamma.texels, ref.texels)


def test_load_errors_name_the_folder_or_file(tmp_path):
    with pytest.raises(BadInput) as e:
        EnvData.load(tmp_path / "nope")
    assert e.value.key == "envmap" and e.value.file == str(tmp_path / "nope")
    _folder(tmp_path, with_coefs=True)
    (tmp_path / art.LIGHT_SG).unlink()
    with pytest.raises(BadInput) as e:
        EnvData.load(tmp_path)
    assert e.value.file == str(tmp_path / art.LIGHT_SG)
