"""χ² goodness-of-fit of a direction sampler against its pdf (Mitsuba/pbrt style)."""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from sgpipe.core.quadrature import gauss_legendre
from sgpipe.core.sphere import tangent_frame


def _cells(axis, width, n_phi=16):
    """Cells in a frame about `axis`: θ' edges geometric from width/4 to π, n_phi azimuths."""
    edges = [0.0]
    e = width / 4.0
    while e < np.pi:
        edges.append(e)
        e *= 1.6
    edges.append(np.pi)
    return np.array(edges), np.linspace(0.0, 2 * np.pi, n_phi + 1)


def chi2_test(sample_fn, pdf_fn, axis, width, n=200_000, seed=1, min_expected=5.0):
    """p-value of the χ² test: counts of `sample_fn(u1, u2) -> (dirs, pdf)` in cells about
    `axis` vs N·∫_cell pdf (GL quadrature in each cell); failed samples (pdf 0) form one more
    cell whose expectation is N(1 − ∫ pdf)."""
    rng = np.random.default_rng(seed)
    u = rng.random((2, n))
    d, pdf = sample_fn(u[0], u[1])
    ok = pdf > 0
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    t, b = tangent_frame(axis)
    th_e, ph_e = _cells(axis, width)
    dl = np.stack([d @ t, d @ b, d @ axis], -1)[ok]
    th = np.arccos(np.clip(dl[:, 2], -1, 1))
    ph = np.mod(np.arctan2(dl[:, 1], dl[:, 0]), 2 * np.pi)
    it = np.clip(np.searchsorted(th_e, th, side="right") - 1, 0, len(th_e) - 2)
    ip = np.clip(np.searchsorted(ph_e, ph, side="right") - 1, 0, len(ph_e) - 2)
    counts = np.bincount(it * (len(ph_e) - 1) + ip, minlength=(len(th_e) - 1) * (len(ph_e) - 1))
    gx, gw = gauss_legendre(10, 0.0, 1.0)
    expected = np.zeros_like(counts, dtype=float)
    for a in range(len(th_e) - 1):
        ct = np.cos(th_e[a]) + (np.cos(th_e[a + 1]) - np.cos(th_e[a])) * gx
        wt = gw * (np.cos(th_e[a]) - np.cos(th_e[a + 1]))
        for c in range(len(ph_e) - 1):
            p = ph_e[c] + (ph_e[c + 1] - ph_e[c]) * gx
            wp = gw * (ph_e[c + 1] - ph_e[c])
            st = np.sqrt(np.maximum(0, 1 - ct * ct))
            dd = (st[:, None, None] * np.cos(p)[None, :, None] * t
                  + st[:, None, None] * np.sin(p)[None, :, None] * b
                  + ct[:, None, None] * axis)
            expected[a * (len(ph_e) - 1) + c] = n * np.sum(pdf_fn(dd) * wt[:, None] * wp[None, :])
    counts = np.append(counts, np.count_nonzero(~ok))
    expected = np.append(expected, max(n - expected.sum(), 0.0))
    order = np.argsort(expected)          # pool small cells (smallest first) into one
    pooled_c = pooled_e = 0.0
    keep_c, keep_e = [], []
    for k in order:
        if expected[k] < min_expected:
            pooled_c += counts[k]
            pooled_e += expected[k]
        else:
            keep_c.append(counts[k])
            keep_e.append(expected[k])
    if pooled_e > 0:
        keep_c.append(pooled_c)
        keep_e.append(pooled_e)
    keep_c, keep_e = np.array(keep_c, float), np.array(keep_e)
    stat = float(np.sum((keep_c - keep_e) ** 2 / np.maximum(keep_e, 1e-300)))
    dof = len(keep_c) - 1
    return float(chi2.sf(stat, dof)), stat, dof, float(expected[:-1].sum() / n)
