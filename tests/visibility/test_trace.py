"""Embree-traced visibility and SSDF on analytic scenes with closed-form answers."""

import numpy as np
import pytest
import trimesh

from sgpipe.io.mesh import build_mesh
from sgpipe.visibility.hemigrid import max_texel_spacing, texel_dirs, texel_spacing
from sgpipe.visibility.ssdf import ssdf_from_visibility
from sgpipe.visibility.trace import TraceTask, build_scene, trace_chunk, trace_visibility

TRACE, RES = 128, 32


def world_dirs(frame, res):
    d = texel_dirs(res)
    return d[..., :1] * frame["tangent"] + d[..., 1:2] * frame["bitangent"] + \
        d[..., 2:] * frame["normal"]


def trace(scene, frame, res=TRACE):
    return trace_visibility(scene, frame["position"], frame["normal"], frame["tangent"],
                            frame["bitangent"], res, 1e-4)


@pytest.mark.parametrize("name", ["slab", "wall", "open"])
def test_traced_visibility_matches_closed_form(scenes, frame, name):
    scene, _, vis_fn, _ = scenes[name]
    vis = trace(scene, frame)
    truth = vis_fn(world_dirs(frame, TRACE))
    # only texels whose centre lies within ~1e-3 rad of the boundary may disagree
    assert np.mean(vis != truth) < 2e-3
    if name == "open":
        assert vis.all()


@pytest.mark.parametrize("name", ["slab", "wall", "open"])
def test_traced_ssdf_matches_closed_form(scenes, frame, name):
    scene, ssdf_fn, _, _ = scenes[name]
    s = ssdf_from_visibility(trace(scene, frame), RES, max_distance=np.pi / 2)
    truth = ssdf_fn(world_dirs(frame, RES))
    err = np.abs(s - truth)
    assert err.max() <= max_texel_spacing(TRACE), err.max()
    assert err.mean() <= 0.25 * texel_spacing(TRACE)
    far = np.abs(truth) > texel_spacing(RES)
    assert np.array_equal(s[far] > 0, truth[far] > 0)


def test_no_self_intersection_on_tessellated_plane_and_convex_mesh():
    # coplanar neighbours of a floor vertex and the faces around a convex vertex lie on or
    # below its tangent plane: every hemisphere ray must escape
    s = trimesh.creation.icosphere(subdivisions=2, radius=3.0)
    g = build_mesh(s.vertices, s.faces)
    n = 9
    x = np.linspace(-1, 1, n)
    X, Z = np.meshgrid(x, x)
    P = np.stack([X.ravel(), np.zeros(n * n), Z.ravel()], 1)
    F = [[i * n + j, (i + 1) * n + j, i * n + j + 1] for i in range(n - 1) for j in range(n - 1)]
    F += [[i * n + j + 1, (i + 1) * n + j, (i + 1) * n + j + 1]
          for i in range(n - 1) for j in range(n - 1)]
    floor = build_mesh(P, np.array(F))
    for m in (g, floor):
        scene = build_scene(m.triangles)
        diag = np.linalg.norm(np.ptp(m.positions, axis=0))
        for i in range(0, len(m.positions), 7):
            vis = trace_visibility(scene, m.positions[i], m.normals[i], m.tangents[i],
                                   m.bitangents[i], 32, 1e-4 * diag)
            assert vis.all(), i


def test_trace_chunk_writes_its_rows(tmp_path, scenes, frame):
    scene, _, _, tri = scenes["slab"]
    tri_path = tmp_path / "tri.npy"
    np.save(tri_path, tri.astype(np.float32))
    mm = tmp_path / "x.f32"
    np.memmap(mm, np.float32, "w+", shape=(5, 8 * 8)).flush()
    pos = np.array([[0.0, 0.0, 0.0], [-5.0, 0.0, 0.0], [5.0, 0.0, 0.0]])
    k = len(pos)
    ones = np.ones((k, 1))
    task = TraceTask(str(tri_path), str(mm), 5, 1, 4, pos, ones * frame["normal"],
                     ones * frame["tangent"], ones * frame["bitangent"], 32, 8, 1e-4, np.pi / 2)
    res = trace_chunk(task)
    X = np.memmap(mm, np.float32, "r", shape=(5, 64))
    assert np.all(X[0] == 0) and np.all(X[4] == 0)
    assert res.rays == 3 * 32 * 32 and (res.start, res.stop) == (1, 4)
    # x = +5 is under the slab (mostly occluded), x = −5 sees the sky beside it
    assert res.visible_fraction[2] < res.visible_fraction[0] < res.visible_fraction[1]
    np.testing.assert_allclose(X[1], ssdf_from_visibility(
        trace(scene, frame, 32), 8).ravel())


@pytest.mark.parametrize("name", ["slab", "wall", "open"])
def test_adaptive_sampling_equals_full_for_extended_occluders(scenes, frame, name):
    from sgpipe.visibility.trace import trace_visibility_counted
    scene = scenes[name][0]
    args = (scene, frame["position"], frame["normal"], frame["tangent"], frame["bitangent"],
            TRACE, 1e-4)
    full, n_full = trace_visibility_counted(*args)
    adaptive, n_adaptive = trace_visibility_counted(*args, sampling="adaptive", res=RES)
    assert np.array_equal(full, adaptive)
    assert n_full == TRACE ** 2 and n_adaptive < 0.5 * n_full
