"""MERL reader/writer, half/difference indexing, and the Wang09 eq 13–14 tabulated model."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from sgpipe.brdf import LUMINANCE, load_merl, make_brdf, read_merl
from sgpipe.brdf.merl import FILE_BYTES, from_half_diff, merl_lookup, to_half_diff
from sgpipe.brdf.shadowing import SHADOW_THETA, smith_g1_ggx
from sgpipe.brdf.tabulated import NDF_THETA
from sgpipe.errors import BadInput

TOOL = Path(__file__).resolve().parents[2] / "tools" / "make_merl_sample.py"
ALPHA = 0.15


def _tool():
    spec = importlib.util.spec_from_file_location("make_merl_sample", TOOL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def merl_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("merl") / "synthetic_ggx_merl.binary"
    assert _tool().main(["--out", str(path)]) == 0
    return path


@pytest.fixture(scope="module")
def merl(merl_path):
    return load_merl(merl_path)


def test_file_size_and_header(merl_path):
    assert merl_path.stat().st_size == FILE_BYTES
    assert tuple(np.fromfile(merl_path, "<i4", 3)) == (90, 90, 180)


def test_half_diff_round_trip():
    rng = np.random.default_rng(0)
    th, td = rng.uniform(0, 1.4, 200), rng.uniform(0, 1.4, 200)
    pd, ph = rng.uniform(-np.pi, np.pi, 200), rng.uniform(-np.pi, np.pi, 200)
    o, i = from_half_diff(th, td, pd, ph)
    h = (o + i) / np.linalg.norm(o + i, axis=1, keepdims=True)
    np.testing.assert_allclose(np.arccos(h[:, 2]), th, atol=1e-9)
    np.testing.assert_allclose(np.sum(i * h, 1), np.cos(td), atol=1e-9)   # θ_d = ∠(i, h)
    got = to_half_diff(o, i)
    np.testing.assert_allclose(got[0], th, atol=1e-9)
    np.testing.assert_allclose(got[2], td, atol=1e-9)
    np.testing.assert_allclose(np.cos(got[3]), np.cos(pd), atol=1e-7)


def test_lookup_reproduces_the_source_model(merl_path):
    src = _tool().DEFAULT_PARAMS
    brdf = make_brdf("ggx", src)
    table = read_merl(merl_path)
    rng = np.random.default_rng(1)
    th = ((rng.integers(0, 80, 300) + 0.5) / 90) ** 2 * np.pi / 2      # cell centres
    td = (rng.integers(0, 60, 300) + 0.5) / 90 * np.pi / 2
    pd = (rng.integers(0, 180, 300) + 0.5) / 180 * np.pi
    o, i = from_half_diff(th, td, pd, rng.uniform(-np.pi, np.pi, 300))
    up = (o[:, 2] > 0.05) & (i[:, 2] > 0.05)
    np.testing.assert_allclose(merl_lookup(table, o[up], i[up]), brdf.eval(o[up], i[up]),
                               rtol=1e-9)


def test_tabulated_fit_recovers_d_s_kd_ks(merl):
    """The source is exactly eq 13 (GGX, Smith G1 S, dielectric η = 1.33): D, S, kd and ks come
    back (ks = ks_GGX/(4α²) because D is peak-normalised and eq 13 has π, not 4)."""
    fit = merl.fit
    src = _tool().DEFAULT_PARAMS
    h = np.stack([np.sin(NDF_THETA), 0 * NDF_THETA, np.cos(NDF_THETA)], -1)
    d_ref = make_brdf("ggx", {"alpha": ALPHA}).ndf(h)
    np.testing.assert_allclose(fit.ndf[:60], d_ref[:60], rtol=0.02, atol=1e-4)
    v = np.stack([np.sin(SHADOW_THETA), 0 * SHADOW_THETA, np.cos(SHADOW_THETA)], -1)
    np.testing.assert_allclose(fit.shadow[:75], smith_g1_ggx(v, ALPHA, ALPHA)[:75], atol=0.01)
    np.testing.assert_allclose(fit.kd, src["kd"], rtol=0.02)
    np.testing.assert_allclose(fit.ks, np.array(src["ks"]) / (4 * ALPHA**2), rtol=0.02)
    assert fit.rel_err < 0.02
    assert fit.pca_basis.shape == (8, 90) and fit.pca_coeffs.shape == (8,)
    np.testing.assert_allclose(fit.pca_mean + fit.pca_coeffs @ fit.pca_basis, fit.shadow,
                               atol=1e-9)


def test_merl_brdf_interface(merl):
    o = np.array([np.sin(0.5), 0.0, np.cos(0.5)])
    a = merl.albedo(o, n=48) @ LUMINANCE
    ref = make_brdf("ggx", _tool().DEFAULT_PARAMS).albedo(o, n=48) @ LUMINANCE
    assert a == pytest.approx(ref, rel=0.03)
    assert merl.microfacet_params()["shadowing"] == 7
    assert merl.microfacet_params()["fresnel"] == 3


def test_truncated_and_wrong_files(tmp_path, merl_path):
    short = tmp_path / "short.binary"
    short.write_bytes(merl_path.read_bytes()[:100000])
    with pytest.raises(BadInput, match="truncated"):
        read_merl(short, key="k")
    bad = tmp_path / "dims.binary"
    bad.write_bytes(np.array([90, 90, 360], "<i4").tobytes() + b"\0" * 64)
    with pytest.raises(BadInput, match="dimensions"):
        read_merl(bad)
    with pytest.raises(BadInput, match="no header"):
        (tmp_path / "tiny.binary").write_bytes(b"\1\2")
        read_merl(tmp_path / "tiny.binary")
