"""tools/sample_normalmaps.py: deterministic files that read back as the analytic normals."""

import sys
from pathlib import Path

import numpy as np

from sgpipe.normalmap.read import read_normal_map

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import sample_normalmaps as samples  # noqa: E402


def test_sample_map_deterministic_and_decodes(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    samples.make(a)
    samples.make(b)
    for f in samples.FILES:
        assert (a / f).read_bytes() == (b / f).read_bytes()
    n = samples.grooves_normals()
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-15)
    np.testing.assert_allclose(read_normal_map(a / samples.FILES[0]), n, atol=4e-5)
    np.testing.assert_allclose(read_normal_map(a / samples.FILES[1]), n, atol=9e-3)
    # grooves: exactly the two tilts ±atan(0.75) in x (top-left cell) away from the cap
    s = samples.GROOVE_SLOPE / np.hypot(1.0, samples.GROOVE_SLOPE)
    assert set(np.round(n[0, :8, 0], 12)) == {round(s, 12), round(-s, 12)}
    # the caps reach the rim tilt: max sin(tilt) close to CAP_RIM_SIN
    tilt = np.hypot(n[..., 0], n[..., 1])
    assert samples.CAP_RIM_SIN - 0.05 < tilt.max() <= samples.CAP_RIM_SIN
