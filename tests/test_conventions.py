"""docs/CONVENTIONS.md says what the code does: its tables and formulas checked against it."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from sgpipe.core.maps import cubemap_dir, dir_to_cubemap, latlong_dir
from sgpipe.core.sg import sg_integral

DOC = (Path(__file__).resolve().parents[1] / "docs" / "CONVENTIONS.md").read_text()
AXES = {"x": 0, "y": 1, "z": 2}


def _face_table():
    rows = re.findall(r"^\s*\| ([+−-][XYZ]) \| ([+−-]?[xyz]) \| ([+−-]?[xyz]) \| ([xyz]) \|$",
                      DOC, re.M)
    assert [r[0] for r in rows] == ["+X", "−X", "+Y", "−Y", "+Z", "−Z"]
    return rows


def _component(d, spec):
    sign = -1.0 if spec[0] in "−-" else 1.0
    return sign * d[..., AXES[spec[-1]]]


def test_cube_face_table_matches_the_code():
    rng = np.random.default_rng(1)
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    face, s, t = dir_to_cubemap(d)
    for k, (_, sc, tc, ma) in enumerate(_face_table()):
        on = face == k
        m = np.abs(d[on, AXES[ma]])
        np.testing.assert_allclose(s[on], 0.5 * (_component(d[on], sc) / m + 1), atol=1e-12)
        np.testing.assert_allclose(t[on], 0.5 * (_component(d[on], tc) / m + 1), atol=1e-12)
        np.testing.assert_allclose(cubemap_dir(k, s[on], t[on]), d[on], atol=1e-12)


def test_latlong_landmarks_as_documented():
    assert "u = 0 at −Z, u = ¼ at +X, u = ½ at +Z" in DOC and "row 0 looks at +Y" in DOC
    for u, v, want in [(0.0, 0.5, (0, 0, -1)), (0.25, 0.5, (1, 0, 0)), (0.5, 0.5, (0, 0, 1)),
                       (0.3, 0.0, (0, 1, 0)), (0.7, 1.0, (0, -1, 0))]:
        np.testing.assert_allclose(latlong_dir(u, v), want, atol=1e-12)


def test_vmf_is_the_documented_sg():
    assert "amplitude κ/(2π(1 − e^{−2κ}))" in DOC
    for kappa in (0.1, 1.0, 30.0, 1e4):
        amp = kappa / (2 * np.pi * (1 - np.exp(-2 * kappa)))
        # the SG with that amplitude integrates to 1, as the density does
        np.testing.assert_allclose(sg_integral(kappa, amp), 1.0, rtol=1e-12)
        x = np.cos(0.3)
        dens = kappa / (4 * np.pi * np.sinh(kappa)) * np.exp(kappa * x) if kappa < 700 else None
        if dens is not None:
            np.testing.assert_allclose(amp * np.exp(kappa * (x - 1)), dens, rtol=1e-12)
