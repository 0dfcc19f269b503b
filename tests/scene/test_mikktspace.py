"""MikkTSpace tangents (sgpipe.io.mikktspace) against the reference C implementation's outputs,
and the meaning of the bitangent sign on a UV-mirrored normal-mapped surface."""

from pathlib import Path

import numpy as np
import pytest

from sgpipe.io.mikktspace import corner_tangents, gltf_primitive_tangents, split_by_tangent

#: mikktspace.c (genTangSpaceDefault, float32) on four meshes: a lat-long sphere, a sheet with
#: its UVs mirrored at x = 0 (seam vertices shared), a jittered grid with a flipped triangle,
#: degenerate UVs and coincident corners, and a torus with sheared, tiled UVs
REFERENCE = Path(__file__).parent / "data" / "mikktspace_reference.npz"
CASES = ("sphere", "mirrored", "messy", "torus")


@pytest.mark.parametrize("case", CASES)
def test_matches_the_reference_implementation(case):
    z = np.load(REFERENCE, allow_pickle=False)
    got = corner_tangents(z[f"{case}_positions"], z[f"{case}_normals"], z[f"{case}_uvs"],
                          z[f"{case}_faces"])
    want = z[f"{case}_tangents"]
    assert got.shape == want.shape
    np.testing.assert_array_equal(got[..., 3], want[..., 3])
    np.testing.assert_allclose(got[..., :3], want[..., :3], atol=2e-5)


def test_reference_cases_cover_both_signs_and_degenerate_triangles():
    z = np.load(REFERENCE, allow_pickle=False)
    w = z["mirrored_tangents"][..., 3]
    assert (w > 0).sum() == (w < 0).sum() > 0
    f = z["messy_faces"]
    assert (f[:, 0] == f[:, 1]).any()     # coincident corners copy a healthy corner


def _mirrored_sheet(n=12):
    """A flat sheet y = 0, x in [−1, 1], z in [0, 1], UV (|x|, z): its two halves mirror the
    texture, sharing the seam's vertices."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    idx = i * (n + 1) + j
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    faces = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3),
                            np.stack([a, d, c], -1).reshape(-1, 3)])
    x, z = 2.0 * i.ravel() / n - 1.0, j.ravel() / n
    pos = np.stack([x, np.zeros_like(x), z], -1)
    nrm = np.tile([0.0, 1.0, 0.0], (len(pos), 1))
    return pos, nrm, np.stack([np.abs(x), z], -1), faces


def test_mirrored_halves_decode_the_surface_the_texture_describes():
    """A normal texture baked from a height field h(u, v) (texture normal ∝ (−h_u, −h_v, 1)),
    decoded with n' = x t + y w (n × t) + z n, gives the normal of the displaced surface on
    both mirrored halves: (−∂h/∂x, 1, −∂h/∂z) with ∂h/∂x = h_u sign(x)."""
    pos, nrm, uv, faces = _mirrored_sheet()
    src, t4, faces2 = split_by_tangent(faces, corner_tangents(pos, nrm, uv, faces))
    seam = np.isclose(pos[:, 0], 0.0).sum()
    assert len(src) == len(pos) + seam            # the seam's vertices split in two
    p, n, uv2 = pos[src], nrm[src], uv[src]
    np.testing.assert_array_equal(p[faces2], pos[faces])
    hu, hv = 0.4 * np.cos(3 * uv2[:, 0]), -0.3 * np.sin(2 * uv2[:, 1])
    tex = np.stack([-hu, -hv, np.ones(len(p))], -1)
    t, w = t4[:, :3], t4[:, 3:]
    got = tex[:, :1] * t + tex[:, 1:2] * w * np.cross(n, t) + tex[:, 2:] * n
    side = np.where(p[:, 0] > 0, 1.0, -1.0)
    inner = ~np.isclose(p[:, 0], 0.0)
    want = np.stack([-hu * side, np.ones(len(p)), -hv], -1)
    np.testing.assert_allclose(got[inner], want[inner], atol=1e-9)
    assert set(np.unique(w[inner])) == {-1.0, 1.0}


def test_gltf_primitive_tangents_use_gltf_uvs_top_down():
    """glTF UVs (v = 0 at the top) are turned to sgpipe's before the computation: on a quad
    whose glTF v grows along −z, the texture's +Y (up in the image) runs along +z = w (n × t)."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], float)
    nrm = np.tile([0.0, 1.0, 0.0], (4, 1))
    uv_gltf = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], float)   # v = 0 at z = 1
    faces = np.array([[0, 2, 1], [0, 3, 2]])
    p, n, uv, t4, f = gltf_primitive_tangents(pos, nrm, uv_gltf, faces)
    up = t4[:, 3:] * np.cross(n, t4[:, :3])
    np.testing.assert_allclose(t4[:, :3], np.tile([1.0, 0, 0], (len(p), 1)), atol=1e-12)
    np.testing.assert_allclose(up, np.tile([0, 0, 1.0], (len(p), 1)), atol=1e-12)
