"""envmap/ contract: writer → reader round trips, layouts, malformed files (one BadInput line)."""
import numpy as np
import pytest

from sgpipe.artifacts import FolderSink
from sgpipe.artifacts import envmap as art
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz, write_exr

RNG = np.random.default_rng(7)


def _strip(n, border, channels=3):
    return RNG.uniform(0.1, 2.0, art.strip_shape(n, border)[:2] + (channels,)).astype(np.float32)


def _pyramid(with_coefs=True):
    res = [8, 4, 4]
    return art.PyramidArtifacts(
        lambdas=np.array([16.0, 8.0, 4.0]), face_res=np.array(res), ratio=2.0,
        mean=np.array([0.5, 0.6, 0.7]), samples=[_strip(n, 1) for n in res],
        values=[_strip(n, 2) for n in res] if with_coefs else None,
        slopes=[-_strip(n, 2) for n in res] if with_coefs else None,
        raw=_strip(16, 1), point_dirs=np.array([[0.0, 1.0, 0.0]]),
        point_energy=np.array([[3.0, 2.0, 1.0]]))


def test_pyramid_round_trip(tmp_path):
    pyr = _pyramid()
    art.write_pyramid(FolderSink(tmp_path), pyr)
    got = art.read_pyramid(tmp_path)
    for k in ("lambdas", "face_res", "mean", "point_dirs", "point_energy"):
        np.testing.assert_array_equal(getattr(got, k), getattr(pyr, k))
    assert got.ratio == pyr.ratio
    for k in ("samples", "values", "slopes"):
        for a, b in zip(getattr(got, k), getattr(pyr, k), strict=True):
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(got.raw, pyr.raw)
    idx = read_npz(tmp_path / art.PYRAMID_INDEX)
    assert idx["offsets"][-1] == sum(6 * (n + 2) ** 2 for n in pyr.face_res)
    assert idx["coef_offsets"][-1] == sum(6 * (n + 4) ** 2 for n in pyr.face_res)
    assert idx["coef_border"] == art.COEF_BORDER and idx["border"] == art.SAMPLE_BORDER
    _, meta = read_exr(tmp_path / art.level_name(1, "slope"), with_metadata=True)
    assert meta["border"] == 2 and meta["quantity"] == "dlnG_dlnlambda" and meta["level"] == 1
    assert (tmp_path / "pyramid/level_00.png").is_file()


def test_pyramid_without_coefficients_reads_none(tmp_path):
    art.write_pyramid(FolderSink(tmp_path), _pyramid(with_coefs=False))
    got = art.read_pyramid(tmp_path)
    assert got.values is None and got.slopes is None and len(got.samples) == 3
    assert "coef_offsets" not in read_npz(tmp_path / art.PYRAMID_INDEX)


def test_pyramid_reader_names_the_bad_file(tmp_path):
    art.write_pyramid(FolderSink(tmp_path), _pyramid())
    bad = tmp_path / art.level_name(2, "coef")
    write_exr(bad, _strip(5, 2))                          # index says face_res 4
    with pytest.raises(BadInput) as e:
        art.read_pyramid(tmp_path)
    line = e.value.one_line()
    assert str(bad) in line and "envmap" in line and "face_res 4" in line and "\n" not in line
    write_exr(bad, _strip(4, 2, channels=2))
    with pytest.raises(BadInput, match="channels"):
        art.read_pyramid(tmp_path)


@pytest.mark.parametrize("name", [art.PYRAMID_INDEX, art.level_name(0), art.RAW_LEVEL])
def test_truncated_file_is_one_bad_input_line(tmp_path, name):
    art.write_pyramid(FolderSink(tmp_path), _pyramid())
    p = tmp_path / name
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    with pytest.raises(BadInput) as e:
        art.read_pyramid(tmp_path)
    assert e.value.file == str(p) and e.value.key == "envmap"
    assert "\n" not in e.value.one_line()


def test_mip_round_trip_and_shapes(tmp_path):
    cube = [_strip(n, 1) for n in (8, 4, 2, 1)]
    dp = [RNG.uniform(0, 1, (n, 2 * n, 3)).astype(np.float32) for n in (8, 4, 2, 1)]
    art.write_mip(FolderSink(tmp_path), cube, dp, dp_b=1.2, coverage=0.9)
    c = art.read_mip(tmp_path, "cube")
    d = art.read_mip(tmp_path, "dp")
    assert c.kind == "cube" and d.kind == "dp" and d.b == pytest.approx(1.2)
    for a, b in zip(c.levels + d.levels, cube + dp, strict=True):
        np.testing.assert_array_equal(a, b)
    idx = read_npz(tmp_path / art.MIP_INDEX)
    assert list(idx["cube_res"]) == [8, 4, 2, 1] and idx["N"] == 8
    assert idx["coverage"] == pytest.approx(0.9)
    write_exr(tmp_path / art.mip_name(1, "dp"), dp[0])
    with pytest.raises(BadInput) as e:
        art.read_mip(tmp_path, "dp")
    assert e.value.file == str(tmp_path / "mip/dp_01.exr")


def test_light_fits_and_irradiance_round_trip(tmp_path):
    sink = FolderSink(tmp_path)
    axes = RNG.normal(size=(3, 3))
    art.write_light_sg(sink, axes=axes, sharpness=[1.0, 2.0, 3.0], amplitude=np.ones((3, 3)),
                       irradiance_rel_err=[0.1, 0.1, 0.1], irradiance_rel_err_eq40=[0.2] * 3)
    art.write_light_sh(sink, lmax=1, coeffs=np.ones((4, 3)), irradiance_coeffs=np.zeros((4, 3)),
                       irradiance_rel_err=[0.3] * 3)
    art.write_irradiance(sink, np.full((4, 8, 3), 0.25, np.float32))
    sg = art.read_light_sg(tmp_path)
    np.testing.assert_array_equal(sg.axes, axes)
    np.testing.assert_array_equal(sg.sharpness, [1.0, 2.0, 3.0])
    sh = art.read_light_sh(tmp_path)
    assert sh["lmax"] == 1 and sh["coeffs"].shape == (4, 3)
    assert art.read_irradiance(tmp_path).shape == (4, 8, 3)
    art.write_light_sg(sink, axes=axes, sharpness=[1.0, 2.0], amplitude=np.ones((3, 3)),
                       irradiance_rel_err=[0.1] * 3, irradiance_rel_err_eq40=[0.2] * 3)
    with pytest.raises(BadInput, match="axes has shape"):
        art.read_light_sg(tmp_path)


def test_store_rebuilds_the_envmap_objects(tmp_path):
    """envmap.store: a built pyramid → the contract → a Pyramid again, same lookups."""
    from sgpipe.envmap import store
    from sgpipe.envmap.maps import latlong_to_cubemap
    from sgpipe.envmap.pyramid import PyramidSettings, build_pyramid
    from sgpipe.core.maps import latlong_texel_dirs
    d = latlong_texel_dirs(16, 32)
    img = 0.5 + 0.4 * d[..., 1:2] * np.ones(3) + 0.1 * (d[..., :1] > 0.5)
    pyr = build_pyramid(latlong_to_cubemap(img, 8), PyramidSettings())
    art.write_pyramid(FolderSink(tmp_path), store.pyramid_artifacts(pyr))
    back = store.load_pyramid(tmp_path)
    p = RNG.normal(size=(50, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    np.testing.assert_allclose(back.lookup(p, 3.0), pyr.lookup(p, 3.0), rtol=1e-6)
    (tmp_path / art.level_name(0, "coef")).unlink()
    with pytest.raises(BadInput) as e:
        store.load_pyramid(tmp_path)
    assert e.value.file.endswith("pyramid/coef_00.exr")
