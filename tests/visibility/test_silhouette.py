"""The adaptive sampler's bound: visibility only changes across projected contour and open
edges, every texel pair such an edge crosses is traced, and the result equals `full`."""

import numpy as np
import pytest
import trimesh

from sgpipe.visibility import _silhouette_jit as sil
from sgpipe.visibility.hemigrid import texel_dirs
from sgpipe.visibility.silhouette import PAD, arc_step, edge_table, silhouette_mark
from sgpipe.visibility.ssdf import ssdf_from_visibility
from sgpipe.visibility.trace import build_scene, trace_visibility_counted

TRACE, RES = 128, 32
FRAME = (np.zeros(3), np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]),
         np.array([0.0, 0.0, -1.0]))          # position, normal, tangent, bitangent


def crossed_pairs(t, a, b):
    """For 4-neighbouring texel pairs of a t×t image (across columns, then rows): a bool mask
    of the pairs whose connecting great-circle arc crosses the arc a–b (brute force)."""
    d = texel_dirs(t)
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    n2 = np.cross(a, b)
    out = []
    for d1, d2 in ((d[:, :-1], d[:, 1:]), (d[:-1], d[1:])):
        n1 = np.cross(d1, d2)
        x = np.cross(n1, n2)
        x *= np.sign(x @ (a + b))[..., None]
        out.append((np.sign(d1 @ n2) != np.sign(d2 @ n2)) & (np.sign(n1 @ a) != np.sign(n1 @ b))
                   & (np.sum(x * (d1 + d2), -1) > 0))
    return out


@pytest.mark.parametrize("t", [32, 128, 512])
def test_every_texel_pair_an_edge_crosses_is_marked(t):
    rng = np.random.default_rng(t)
    crossed = 0
    for i in range(60 if t < 512 else 15):
        a, b = rng.normal(size=3), rng.normal(size=3)
        if i % 3 == 0:
            a[2] = 0.0                                    # ends on the horizon
        if i % 4 == 1:
            b = a / np.linalg.norm(a) + 0.02 * rng.normal(size=3)   # a short arc
        a[2], b[2] = abs(a[2]), abs(b[2])
        mark = np.zeros((t, t), bool)
        assert sil._mark_arc(mark, a, b, arc_step(t), PAD)
        cols, rows = crossed_pairs(t, a, b)
        crossed += cols.sum() + rows.sum()
        assert mark[:, :-1][cols].all() and mark[:, 1:][cols].all()
        assert mark[:-1][rows].all() and mark[1:][rows].all()
        assert mark.mean() < 0.5 or t == 32
    assert crossed > 5 * t


def test_dir_to_texel_inverts_the_texel_grid():
    d = texel_dirs(64)
    c, r = np.vectorize(lambda x, y, z: sil.dir_to_texel(x, y, z, 64))(d[..., 0], d[..., 1],
                                                                        d[..., 2])
    grid = np.broadcast_to(np.arange(64) + 0.5, (64, 64))
    np.testing.assert_allclose(c, grid, atol=1e-9)
    np.testing.assert_allclose(r, grid.T, atol=1e-9)


def test_edge_table_open_and_folded_edges():
    box = trimesh.creation.box()
    e = edge_table(box.triangles)
    assert len(e.p0) == 18 and (e.fb >= 0).all() and (e.flip == 1).all()
    quad = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]]])
    e = edge_table(quad)
    assert len(e.p0) == 5 and (e.fb == -1).sum() == 4
    flipped = quad.copy()
    flipped[1] = flipped[1][::-1]                         # the second face wound the other way
    e = edge_table(flipped)
    assert (e.flip == -1).sum() == 1


def test_interior_edges_of_a_flat_floor_are_not_contours():
    # seen from above, a tessellated plane has only its rim as a possible boundary
    x = np.linspace(-1, 1, 5)
    tri = []
    for i in range(4):
        for j in range(4):
            a, b, c, d = ((x[i], -1, x[j]), (x[i + 1], -1, x[j]), (x[i + 1], -1, x[j + 1]),
                          (x[i], -1, x[j + 1]))
            tri += [[a, c, b], [a, d, c]]
    e = edge_table(np.array(tri))
    mark = silhouette_mark(e, np.zeros(3), FRAME[2], FRAME[3], FRAME[1], 64)
    assert mark is not None and not mark.any()            # the whole plane is below the horizon
    mark = silhouette_mark(e, np.array([0.0, -3.0, 0.0]), FRAME[2], FRAME[3], FRAME[1], 64)
    # from below, the rim bounds the projected square: only a band around it is marked
    assert mark is not None and 0 < mark.mean() < 0.25
    assert not mark[24:40, 24:40].any()


def test_an_edge_through_the_ray_origin_traces_everything():
    tri = np.array([[[-1.0, -0.5, 0.0], [1.0, 1.5, 0.0], [0.0, 1.0, 1.0]]])
    assert silhouette_mark(edge_table(tri), np.array([0.0, 0.5, 0.0]), FRAME[2], FRAME[3],
                           FRAME[1], 32) is None


def _pole(width, x=1.0, h=2.0):
    """A thin square pole at (x, 0, 0), `width` wide, from y = −0.5 to y = h."""
    return trimesh.creation.box(extents=(width, h + 0.5, width)).apply_translation(
        (x, h / 2 - 0.25, 0.0)).triangles


def _small_sphere(r=0.03, at=(0.7, 1.2, 0.4)):
    return trimesh.creation.icosphere(subdivisions=2, radius=r).apply_translation(at).triangles


def _far_box():
    """A low box far away on the plane: an occluder in the horizon band (elevation < 1°)."""
    return trimesh.creation.box(extents=(0.5, 0.1, 3.0)).apply_translation(
        (-4.0, 0.045, 1.0)).triangles


def _trace_both(tri, offset=1e-4):
    scene = build_scene(tri)
    full, n_full = trace_visibility_counted(scene, *FRAME, TRACE, offset)
    ad, n_ad = trace_visibility_counted(scene, *FRAME, TRACE, offset, sampling="adaptive",
                                        res=RES)
    return full, n_full, ad, n_ad


@pytest.mark.parametrize("name, tri", [("pole", _pole(0.03)), ("sphere", _small_sphere()),
                                       ("horizon box", _far_box()),
                                       ("all three", np.concatenate([_pole(0.03),
                                                                     _small_sphere(),
                                                                     _far_box()]))])
def test_adaptive_equals_full_on_occluders_between_coarse_samples(name, tri):
    full, n_full, ad, n_ad = _trace_both(tri)
    # the occluder is seen, but smaller than an output texel (4×4 trace texels) somewhere
    assert 0 < (~full).sum() < 0.05 * full.size
    assert np.array_equal(ad, full), name
    assert n_ad < 0.5 * n_full
    np.testing.assert_array_equal(ssdf_from_visibility(ad, RES),
                                  ssdf_from_visibility(full, RES))


def test_faces_wound_the_other_way_keep_their_contours():
    # the pole's side facing the vertex wound the other way: its contour edges join faces of
    # opposite winding, which the edge table's flip accounts for
    tri = _pole(0.03).copy()
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    near = n[:, 0] < -0.5 * np.linalg.norm(n, axis=1)
    assert near.sum() == 2
    tri[near] = tri[near][:, ::-1]
    full, _, ad, _ = _trace_both(tri)
    assert (~full).sum() > 0 and np.array_equal(ad, full)


def test_one_ray_per_output_texel_would_miss_the_pole():
    # what the refinement buys: the pole's texels fall between the centres of 4×4 blocks
    full, _, ad, _ = _trace_both(_pole(0.03))
    k = TRACE // RES
    coarse = np.repeat(np.repeat(full[k // 2::k, k // 2::k], k, 0), k, 1)
    assert (coarse != full).sum() > 0 and np.array_equal(ad, full)


def test_probes_that_disagree_trace_the_region_whole(monkeypatch):
    # with no edges at all the whole image is one region: its probes see both the slab
    # and the sky, so the region is traced ray by ray and the result is still exact
    slab = np.array([[[0, 1, -50], [50, 1, -50], [50, 1, 50]], [[0, 1, -50], [50, 1, 50],
                                                                [0, 1, 50]]], float)
    scene = build_scene(slab)
    full, _ = trace_visibility_counted(scene, *FRAME, TRACE, 1e-4)
    empty = edge_table(np.zeros((0, 3, 3)))
    monkeypatch.setattr(type(scene), "edges", property(lambda self: empty))
    ad, n = trace_visibility_counted(scene, *FRAME, TRACE, 1e-4, sampling="adaptive")
    assert np.array_equal(ad, full) and n == TRACE ** 2 + 3


def test_regions_and_probes():
    mark = np.zeros((6, 6), bool)
    mark[:, 2] = True                                     # a wall splits the image in two
    mark[3, 3:] = True                                    # and the right half once more
    rr, r0, r1, region, m = sil.unmarked_regions(mark)
    assert m == 3
    vis = np.zeros((6, 6), bool)
    sil.fill_regions(vis, rr, r0, r1, region, np.array([True, False, True]))
    assert vis[:, :2].all() and not vis[:3, 3:].any() and vis[4:, 3:].all()
    probes = sil.probe_texels(rr, r0, r1, region, m, 6)
    assert tuple(probes[0]) == (0, 3 * 6, 5 * 6 + 1) and tuple(probes[2]) == (24 + 3, 30 + 3,
                                                                           30 + 5)
    assert all(not mark.ravel()[p] for p in probes.ravel())
