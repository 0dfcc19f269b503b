"""benchmarks/_scenes.py's inputs are what benchmarks/bench_render.py says they are: the
mirror-lobe Gaussians (μ the mirror direction of the view, w the BRDF's specular lobe × cosine
there, zero at and below the transport stage's horizon) in the local frame each vertex's
tangents define, kept through the stage's compact artifact format; green06's speed scene renders
finite radiance from them; the Han07 full-frame variant shades every pixel."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from sgpipe.brdf import make_brdf
from sgpipe.core.sphere import tangent_frame
from sgpipe.transport.views import view_set

_FILE = Path(__file__).resolve().parents[2] / "benchmarks" / "_scenes.py"
_spec = importlib.util.spec_from_file_location("bench_scenes", _FILE)
S = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(S)         # benchmarks/ is not an installed package


def test_mirror_gaussians_are_the_mirror_lobes():
    """Per vertex and view: μ unit, at the view's angle from n on the other side of it
    ((μ + v) ∥ n); w = f_s(o, i)·cos θ_i with o, i the view and μ projected on the vertex's
    (t, b, n) one at a time; views with n·v ≤ min_cos weigh zero, the others more."""
    rng = np.random.default_rng(3)
    n = rng.normal(size=(40, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    t, b = tangent_frame(n)
    brdf = make_brdf("ggx", {"alpha": 0.15, "kd": 0.1, "ks": 0.8})
    min_cos = 0.05
    mu, sigma, w = S.mirror_gaussians(brdf, SimpleNamespace(normals=n, tangents=t,
                                                           bitangents=b), min_cos, 0.2)
    views = view_set()[0]
    assert mu.shape == (40, 92, 1, 3) and w.shape == (40, 92, 1, 3)
    assert np.all(sigma == 0.2)
    c = n @ views.T
    np.testing.assert_allclose(np.linalg.norm(mu[:, :, 0], axis=-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("xvk,xk->xv", mu[:, :, 0], n), c, atol=1e-12)
    s = mu[:, :, 0] + views[None]
    np.testing.assert_allclose(np.cross(s, n[:, None]), 0.0, atol=1e-12)
    for x in range(0, 40, 7):
        frame = np.stack([t[x], b[x], n[x]])
        for v in range(92):
            o, i = frame @ views[v], frame @ mu[x, v, 0]
            ref = brdf.specular(o, i) * max(i[2], 0.0) if c[x, v] > min_cos else 0.0
            np.testing.assert_allclose(w[x, v, 0], np.broadcast_to(ref, (3,)), rtol=1e-12,
                                       atol=0.0)
    assert np.all(w[c <= min_cos] == 0.0) and np.all(w[c > min_cos] > 0.0)


@pytest.mark.opencl
def test_transport_scene_round_trips_the_artifacts_and_renders(tmp_path):
    """The written artifacts decode to the mirror lobes (directions within the octahedral
    code's 1e-3, σ the fit's lower bound, weighted exactly the views above the horizon,
    floor included when glossy); every shaded pixel of the 48² frame finite, ≥ 0, the ball lit."""
    from sgpipe.artifacts.transport import read_gaussians, read_packed_gaussians
    from sgpipe.io import read_npz
    r, fr, nv = S.transport_scene(tmp_path, size=48, glossy_floor=True,
                                  extra=["transport.sphere_subdivisions=2",
                                         "visibility.sphere_subdivisions=2"])
    assert nv == 162 + 10201
    folder = tmp_path / "transport"
    views = view_set()[0]
    for obj in ("ball", "floor"):
        mu, sigma, w, stored = read_gaussians(folder, obj)
        n = read_npz(folder / obj / "geometry.npz")["normals"].astype(float)
        c = n @ views.T
        up = c > np.sin(np.radians(1.0))            # transport.min_view_elevation_deg
        assert np.array_equal(np.any(w[:, :, 0] != 0, -1), up)
        mirror = 2 * c[..., None] * n[:, None] - views[None]
        mirror /= np.linalg.norm(mirror, axis=-1, keepdims=True)
        assert np.max(np.linalg.norm(mu[:, :, 0][up] - mirror[up], axis=-1)) < 1e-3
        lo = read_packed_gaussians(folder, obj)["sigma_range"][0]    # σ code 0
        if up.any():
            np.testing.assert_allclose(sigma[stored], lo, rtol=1e-9)
    rgb = r.shade("transport", fr)
    assert len(rgb) == len(fr.index) > 0
    assert np.all(np.isfinite(rgb)) and np.all(rgb >= 0)
    assert rgb[fr.obj == 0].mean() > 0


def test_full_frame_normal_map_variant_shades_every_pixel(tmp_path):
    """NORMALMAP_FULL_FRAME: the plane meets every pixel ray (through the real stages)."""
    _, fr = S.normalmap_scene(tmp_path, size=32, extra=S.NORMALMAP_FULL_FRAME)
    assert len(fr.index) == 32 * 32
    assert fr.duv is not None and np.all(np.isfinite(fr.duv))
