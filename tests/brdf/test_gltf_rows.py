"""GltfRows (per-row glTF parameters) against the uniform `gltf_pbr` BRDF row by row, and its
sampler against its own pdf."""

from __future__ import annotations

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.brdf.gltf_rows import GltfRows

RNG = np.random.default_rng(7)
N = 6
BASE = RNG.random((N, 3))
METAL = np.array([0.0, 1.0, 0.5, 0.2, 1.0, 0.0])
ROUGH = np.array([0.06, 0.2, 0.5, 0.9, 0.35, 0.03])
ANISO = np.array([0.0, 0.0, 0.3, 0.0, 0.7, 0.0])


def _dirs(n, seed):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _uniform(k):
    return make_brdf("gltf_pbr", {"base_color": BASE[k].tolist(), "metallic": METAL[k],
                                  "roughness": ROUGH[k], "anisotropy": ANISO[k]})


def test_rows_match_the_uniform_model():
    rows = GltfRows(np.repeat(BASE, 50, 0), np.repeat(METAL, 50), np.repeat(ROUGH, 50),
                    np.repeat(ANISO, 50))
    o, i = _dirs(N * 50, 1), _dirs(N * 50, 2)
    f = rows.eval(o, i)
    for k in range(N):
        s = slice(50 * k, 50 * (k + 1))
        np.testing.assert_allclose(f[s], _uniform(k).eval(o[s], i[s]), rtol=1e-10, atol=1e-14)
    sub = rows.take(np.arange(50, 100))
    np.testing.assert_allclose(sub.eval(o[50:100], i[50:100]), f[50:100])


@pytest.mark.parametrize("k", range(N))
def test_sampler_estimates_the_albedo(k):
    """∫ f cos by the rows' own sampler equals the uniform model's albedo (its sampler was
    checked against quadrature and χ²): the pdf is the density of `sample`."""
    n = 40000
    rows = GltfRows(np.repeat(BASE[k:k + 1], n, 0), METAL[k], ROUGH[k], ANISO[k])
    o = np.tile([np.sin(0.6), 0.2, np.cos(0.6)], (n, 1))
    o /= np.linalg.norm(o, axis=1, keepdims=True)
    u = np.random.default_rng(k).random((2, n))
    i, pdf = rows.sample(o, u[0], u[1])
    np.testing.assert_allclose(pdf[pdf > 0], rows.pdf(o, i)[pdf > 0], rtol=1e-9)
    w = np.where(pdf > 0, np.maximum(i[:, 2], 0) / np.where(pdf > 0, pdf, 1.0), 0.0)
    est = (rows.eval(o, i) * w[:, None]).mean(0)
    ref = _uniform(k).albedo(o[0], n=128)
    np.testing.assert_allclose(est, ref, rtol=0.03, atol=2e-3)
