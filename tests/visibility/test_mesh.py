"""Scene geometry loading (sgpipe.io.mesh): transforms, normals, tangents, bad meshes."""

import numpy as np
import pytest
import trimesh

from sgpipe.config.sections.scene import ObjectSpec, SceneSection
from sgpipe.errors import BadInput
from sgpipe.io.mesh import build_mesh, load_object, load_scene, object_matrix

QUAD_OBJ = """v 0 0 0
v 2 0 0
v 0 0 -1
v 2 0 -1
vt 0 0
vt 1 0
vt 0 1
vt 1 1
vn 0 1 0
f 1/1/1 2/2/1 3/3/1
f 2/2/1 4/4/1 3/3/1
"""


def test_object_matrix_order_scale_rotate_xyz_translate():
    M = object_matrix((1.0, 2.0, 3.0), (90.0, 90.0, 0.0), 2.0)
    # x then y: e_y -(Rx 90)-> e_z -(Ry 90)-> e_x ; scaled by 2, translated
    np.testing.assert_allclose(M[:3, :3] @ [0, 1, 0] + M[:3, 3], [3.0, 2.0, 3.0], atol=1e-12)


def test_obj_with_uvs_transform_normals_and_uv_tangents(tmp_path):
    p = tmp_path / "quad.obj"
    p.write_text(QUAD_OBJ)
    obj = ObjectSpec(name="q", mesh=str(p), translate=(0.0, 1.0, 0.0), rotate_deg=(0, 90, 0),
                     scale=3.0, material="m")
    g = load_object(obj)
    assert g.has_uvs and g.material == "m" and g.warnings == {}
    R = object_matrix(rotate_deg=(0, 90, 0))[:3, :3]
    np.testing.assert_allclose(g.positions[1], 3.0 * R @ [2, 0, 0] + [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(g.normals, np.tile([0.0, 1.0, 0.0], (4, 1)), atol=1e-12)
    # u increases along +x in the file => tangent = R x
    np.testing.assert_allclose(g.tangents, np.tile(R @ [1.0, 0, 0], (4, 1)), atol=1e-12)
    np.testing.assert_allclose(g.bitangents, np.cross(g.normals, g.tangents))


def test_missing_normals_are_area_weighted_and_default_tangent_is_azimuthal():
    s = trimesh.creation.icosphere(subdivisions=2)
    g = build_mesh(s.vertices, s.faces)
    n_true = s.vertices / np.linalg.norm(s.vertices, axis=1, keepdims=True)
    assert np.min(np.sum(g.normals * n_true, axis=1)) > 0.99
    az = np.cross(g.normals, [0.0, 1.0, 0.0])
    ok = np.linalg.norm(az, axis=1) > 1e-3
    az = az[ok] / np.linalg.norm(az[ok], axis=1, keepdims=True)
    np.testing.assert_allclose(g.tangents[ok], az, atol=1e-12)
    assert np.allclose(np.sum(g.tangents * g.normals, axis=1), 0.0, atol=1e-12)


def test_degenerate_triangles_and_unreferenced_vertices_are_counted():
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 2, 2], [5, 5, 5.0]])
    F = np.array([[0, 1, 2], [0, 0, 1], [0, 1, 1], [0, 1, 0]])
    g = build_mesh(P, F)
    assert g.warnings == {"degenerate_triangles_removed": 3, "unreferenced_vertices_removed": 2}
    assert len(g.positions) == 3 and g.faces.tolist() == [[0, 1, 2]]
    colinear = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]])
    g = build_mesh(colinear, [[0, 1, 2], [0, 1, 3]])
    assert g.warnings["degenerate_triangles_removed"] == 1


@pytest.mark.parametrize("P,F,msg", [
    (np.zeros((0, 3)), np.zeros((0, 3), int), "empty"),
    (np.array([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]]), [[0, 1, 2]], "not finite"),
    (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), [[0, 1, 3]], "out of range"),
    (np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]]), [[0, 1, 2]], "degenerate"),
])
def test_bad_meshes_are_bad_input(P, F, msg):
    with pytest.raises(BadInput, match=msg) as e:
        build_mesh(P, F, source="x.obj", key="scene.objects.0.mesh")
    assert "x.obj" in e.value.one_line() and "scene.objects.0.mesh" in e.value.one_line()


def test_bad_files_name_the_file(tmp_path):
    nan = tmp_path / "nan.obj"
    nan.write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing\n")
    junk = tmp_path / "junk.glb"
    junk.write_bytes(b"\x00not a glb file at all")
    for path, msg in ((nan, "vertex 2"), (empty, "empty"), (junk, "cannot load|empty|not a")):
        with pytest.raises(BadInput, match=msg) as e:
            load_scene(SceneSection(objects=[ObjectSpec(name="a", mesh=str(path))]))
        assert path.name in e.value.one_line() and e.value.key == "scene.objects.0.mesh"


@pytest.mark.parametrize("ext", ["ply", "glb"])
def test_ply_and_glb(tmp_path, ext):
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    path = tmp_path / f"box.{ext}"
    box.export(path)
    g = load_object(ObjectSpec(name="b", mesh=str(path), translate=(0.0, 5.0, 0.0)))
    np.testing.assert_allclose(g.positions.min(0), [-0.5, 4.0, -1.5], atol=1e-6)
    np.testing.assert_allclose(g.positions.max(0), [0.5, 6.0, 1.5], atol=1e-6)
    assert np.allclose(np.linalg.norm(g.normals, axis=1), 1.0)


def test_analytic_sphere_object_uses_exact_normals():
    g = load_object(ObjectSpec(name="s", sphere_radius=2.0, translate=(1.0, 0.0, 0.0)),
                    sphere_subdivisions=2)
    r = g.positions - [1.0, 0.0, 0.0]
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), 2.0)
    np.testing.assert_allclose(g.normals, r / 2.0, atol=1e-12)


def test_obj_that_is_not_utf8_loads(tmp_path):
    """A valid OBJ with one Latin-1 byte (a comment written by an old exporter) failed with
    "No module named 'charset_normalizer'": trimesh needs it to decode such text."""
    p = tmp_path / "latin1.obj"
    p.write_bytes(QUAD_OBJ.encode() + "# mod\xe8le export\xe9\n".encode("latin-1"))
    g = load_object(ObjectSpec(name="q", mesh=str(p)))
    assert len(g.positions) == 4 and len(g.faces) == 2
