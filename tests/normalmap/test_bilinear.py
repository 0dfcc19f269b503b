"""`normalmap.bilinear_samples`: the pyramid's levels ≥ 1 built from s × s sub-samples of the
bilinear normal field the reference reads (sgpipe/normalmap/bilinear.py)."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from sgpipe.artifacts import normalmap as art
from sgpipe.normalmap.bilinear import bilinear_normals, continuum_pyramid, level_shift
from sgpipe.normalmap.pyramid import mean_normal_pyramid
from sgpipe.normalmap.read import decode_normals
from sgpipe.normalmap.sh import ndf_sh_pyramid
from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid
from sgpipe.reference._sampling_jit import tex_bilinear
from sgpipe.stages import normalmap as stage

from .test_stage import make

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import sample_normalmaps  # noqa: E402


def _texels(n=16):
    """A grooves crop's texel values c = (n + 1)/2, quantised to 16 bits as the files are."""
    nrm = sample_normalmaps.grooves_normals(256)[56:56 + n, 56:56 + n]   # four cells meet
    return np.round((nrm * 0.5 + 0.5) * 65535) / 65535


def _reference_read(c, x, y):
    """The reference's normal (Monte Carlo path: tex_bilinear, then normal_mapped_frame's
    decode) at texel-space points x (along u), y (down the rows), texel k spanning [k, k + 1)."""
    n = c.shape[0]
    uv = np.stack([np.ravel(x) / n, 1.0 - np.ravel(y) / n], axis=1)
    return decode_normals(tex_bilinear(c, uv)).reshape(np.shape(x) + (3,))


@pytest.mark.parametrize("s", [1, 2, 4])
def test_subsamples_are_the_references_bilinear_read(s):
    """Sub-sample (r, q) of the s·n grid is the reference's read at the sub-texel centre
    ((q + ½)/s, (r + ½)/s), repeat addressing included (the grid's first and last rows and
    columns straddle the wrap); a half-texel shift of the positions is far off."""
    c = _texels()
    n = c.shape[0]
    got = bilinear_normals(c, s)
    assert got.shape == (n * s, n * s, 3)
    y, x = np.meshgrid((np.arange(n * s) + 0.5) / s, (np.arange(n * s) + 0.5) / s,
                       indexing="ij")
    np.testing.assert_allclose(got, _reference_read(c, x, y), rtol=0, atol=1e-12)
    if s == 1:       # the texel centres: exactly the decoded texels (today's pyramid input)
        np.testing.assert_array_equal(got, decode_normals(c))
    for dx, dy in ((0.5, 0.0), (0.0, 0.5)):
        off = np.abs(got - _reference_read(c, x + dx, y + dy)).max()
        assert off > 0.1, (s, dx, dy, off)


def _exact_mean(c, row, col, level, q=256):
    """The mean of the bilinear normal field over texel (row, col) of `level` by a q × q
    midpoint rule (the field is piecewise smooth, kinks on texel-centre lines)."""
    b = 1 << level
    t = (np.arange(q) + 0.5) / q * b
    y, x = np.meshgrid(row * b + t, col * b + t, indexing="ij")
    return _reference_read(c, x, y).reshape(-1, 3).mean(axis=0)


def test_level1_mean_converges_to_the_bilinear_fields_mean():
    """A level-1 texel's mean normal from s × s sub-samples per finest texel against the exact
    mean of the bilinear field over it (256² quadrature): s = 4 within 2e-3 on every texel,
    while the texel centres (s = 1, today's pyramid) miss it by more than 10× that on some
    texels (the grooves' kinks)."""
    c = _texels()
    nrm = decode_normals(c)
    exact = np.array([[_exact_mean(c, r, q, 1) for q in range(8)] for r in range(8)])
    err = {}
    for s in (1, 2, 4):
        lev1 = continuum_pyramid(nrm, bilinear_normals(c, s), s, None)[1]
        err[s] = np.abs(lev1 - exact).max()
    assert err[4] < 2e-3, err
    assert err[1] > 10 * err[4], err
    assert err[4] < err[2] < err[1], err


def test_pyramids_drop_the_subsample_levels():
    """continuum_pyramid's level ℓ ≥ 1 is level ℓ + log2 s of the sub-sample map's plain
    pyramid (mean and SH, band by band or not), level 0 the map itself; the vMF fit with
    sub-samples keeps the map's level count and level 0, and with s = 1 is today's fit."""
    c = _texels()
    nrm = decode_normals(c)
    for s in (2, 4):
        fine = bilinear_normals(c, s)
        k = level_shift(s)
        got = continuum_pyramid(nrm, fine, s, None, band_rows=3)
        want = mean_normal_pyramid(fine)
        assert len(got) == 5
        np.testing.assert_array_equal(got[0], nrm)
        for a, b in zip(got[1:], want[k + 1:]):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
        sh = ndf_sh_pyramid(fine, 2)
        got = stage._pyramids(nrm, c, s, None)[1](stage._sh_map(2), None)
        np.testing.assert_array_equal(got[0], ndf_sh_pyramid(nrm, 2)[0])
        for a, b in zip(got[1:], sh[k + 1:]):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-14)
    st = VMFSettings(lobes=2)
    base = fit_vmf_pyramid(nrm, st)
    same = fit_vmf_pyramid(nrm, st, fine=bilinear_normals(c, 1))
    for a, b in zip(base.alpha + base.alpha_r, same.alpha + same.alpha_r):
        np.testing.assert_array_equal(a, b)
    sub = fit_vmf_pyramid(nrm, st, fine=bilinear_normals(c, 2))
    assert [a.shape for a in sub.alpha] == [a.shape for a in base.alpha]
    np.testing.assert_array_equal(sub.alpha[0].sum(2), 1.0)
    # the fit sees the in-between normals: its lobes' mean moves towards the field's mean
    exact = np.array([[_exact_mean(c, r, q, 1, 64) for q in range(8)] for r in range(8)])
    mix = lambda p: p.alpha_r[1].astype(float).sum(2)  # noqa: E731
    assert np.abs(mix(sub) - exact).mean() < 0.5 * np.abs(mix(base) - exact).mean()


def test_stage_with_subsamples_is_byte_identical_and_differs_from_texels(tmp_path):
    """`bilinear_samples: 2` (the default) through the stage: two fresh runs give the same bytes; the level
    ≥ 1 artifacts differ from `bilinear_samples: 1`, level 0's normals do not."""
    out = {}
    for tag, extra in (("a", ""), ("b", ", bilinear_samples: 2"),
                       ("one", ", bilinear_samples: 1")):
        d = tmp_path / tag
        d.mkdir()
        stage.run(make(d, extra=extra), d / "out")
        out[tag] = d / "out" / "normalmap"
    m = [json.loads((out[t] / "manifest.json").read_text())["outputs"] for t in ("a", "b")]
    assert m[0] == m[1]
    v2, v1 = art.read_vmf(out["a"], "grooves"), art.read_vmf(out["one"], "grooves")
    # level 0 holds the same delta lobe per texel (its slot follows the new level 1)
    np.testing.assert_array_equal(v2.alpha_r[0].sum(2), v1.alpha_r[0].sum(2))
    assert not np.array_equal(v2.alpha_r[1], v1.alpha_r[1])
    b2, b1 = art.read_baselines(out["a"], "grooves"), art.read_baselines(out["one"], "grooves")
    np.testing.assert_array_equal(b2["mean"][0], b1["mean"][0])
    assert np.abs(b2["mean"][2] - b1["mean"][2]).max() > 1e-3


def test_bilinear_samples_outside_1_2_4_is_bad_input(tmp_path):
    from sgpipe.errors import BadInput
    with pytest.raises(BadInput, match="1, 2, 4") as e:
        make(tmp_path, extra=", bilinear_samples: 3")
    assert "normalmap.bilinear_samples" in e.value.one_line()
