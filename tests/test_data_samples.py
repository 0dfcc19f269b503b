"""data_samples/: reproducible from tools/make_data_samples.py, and physically what it claims."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from sgpipe.io import read_exr

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "data_samples"
TOOLS = ROOT / "tools"


def _load_generator():
    sys.path.insert(0, str(TOOLS))
    spec = importlib.util.spec_from_file_location("make_data_samples",
                                                  TOOLS / "make_data_samples.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory):
    out = tmp_path_factory.mktemp("data_samples")
    assert _load_generator().main(["--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def info():
    return json.loads((SAMPLES / "env_info.json").read_text())


# ---------------------------------------------------------------- helpers written from docs/CONVENTIONS.md


def latlong_solid_angles(h, w):
    """Exact solid angle of each lat-long texel (theta band x phi slice)."""
    t = np.pi * np.arange(h + 1) / h
    return np.broadcast_to(((2 * np.pi / w) * (np.cos(t[:-1]) - np.cos(t[1:])))[:, None], (h, w))


def latlong_centre_dirs(h, w):
    """CONVENTIONS: pixel centre (u, v) -> phi = 2 pi u, theta = pi v,
    d = (sin theta sin phi, cos theta, -sin theta cos phi)."""
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    theta, phi = np.meshgrid(np.pi * v, 2 * np.pi * u, indexing="ij")
    return np.stack([np.sin(theta) * np.sin(phi), np.cos(theta),
                     -np.sin(theta) * np.cos(phi)], -1)


def read_obj(path):
    """Minimal OBJ parser for the sample files: (v, vt or None, vn, faces with shared indices)."""
    v, vt, vn, f = [], [], [], []
    for line in Path(path).read_text().splitlines():
        tag, *rest = line.split() or [""]
        if tag == "v":
            v.append([float(x) for x in rest])
        elif tag == "vt":
            vt.append([float(x) for x in rest])
        elif tag == "vn":
            vn.append([float(x) for x in rest])
        elif tag == "f":
            corners = [c.split("/") for c in rest]
            assert len(corners) == 3 and all(len(set(c) - {""}) == 1 for c in corners)
            f.append([int(c[0]) - 1 for c in corners])
    return (np.array(v), np.array(vt) if vt else None, np.array(vn), np.array(f))


# ---------------------------------------------------------------- reproducibility


def test_regenerated_files_are_byte_identical(regenerated):
    committed = sorted(p.name for p in SAMPLES.iterdir() if p.is_file())
    produced = sorted(p.name for p in regenerated.iterdir() if p.is_file())
    assert committed == produced
    differ = [n for n in committed
              if (SAMPLES / n).read_bytes() != (regenerated / n).read_bytes()]
    assert differ == []


# An ulp of difference in a transcendental function (numpy's sin/cos/exp differ between CPU
# families) must not move a written value across a rounding boundary. The generators use only
# correctly rounded arithmetic otherwise, so this margin makes the bytes the same on any CPU.
ULP_MARGIN = 1e-13   # relative; a numpy sin/cos/exp result is within a few 1e-16 of exact


def _decimal_margin(x, nd=6):
    """Distance of x·10^nd from the nearest rounding boundary (k + 0.5), relative to |x|."""
    y = np.asarray(x, np.float64).ravel() * 10.0 ** nd
    d = np.abs(np.abs(y - np.floor(y)) - 0.5)
    return d / np.maximum(np.abs(y), 1.0)


def _float_margin(x, dtype):
    """Relative distance of x from the nearest midpoint between two `dtype` values."""
    x = np.asarray(x, np.float64).ravel()
    x = x[x != 0]
    r = x.astype(dtype).astype(np.float64)
    up = np.nextafter(r.astype(dtype), np.array(np.inf, dtype)).astype(np.float64)
    dn = np.nextafter(r.astype(dtype), np.array(-np.inf, dtype)).astype(np.float64)
    mid = np.where(x >= r, (r + up) / 2, (r + dn) / 2)
    return np.abs(x - mid) / np.abs(x)


def test_written_values_are_far_from_rounding_boundaries():
    gen = _load_generator()
    meshes, env = gen.meshes, gen.env
    for name, arrays in {"sphere.obj": meshes.uv_sphere(), "teapot.obj": meshes.teapot()[:3],
                         "floor.obj": meshes.floor_plane()}.items():
        for a in arrays:
            if np.issubdtype(np.asarray(a).dtype, np.floating):
                assert _decimal_margin(a).min() > ULP_MARGIN, name
    h, w = gen.ENV_SIZE
    sky, sky_sun = env.make_sky_sun(h, w)
    studio, _ = env.make_studio(h, w)
    for name, img in {"sky_sun.exr": sky_sun, "studio.exr": studio}.items():
        assert _float_margin(img, np.float16).min() > ULP_MARGIN, name
    height, normals = gen.make_normal_map()
    assert _float_margin(height, np.float32).min() > ULP_MARGIN, "bump_height.exr"
    assert _float_margin(normals * 0.5 + 0.5, np.float16).min() > ULP_MARGIN, "normal_map.exr"
    assert _decimal_margin((normals * 0.5 + 0.5) * 255.0, 0).min() > ULP_MARGIN, "normal_map.png"


def test_obj_samples_have_no_negative_zeros():
    for name in ("sphere.obj", "teapot.obj", "floor.obj"):
        assert "-0.000000" not in (SAMPLES / name).read_text(), name


def test_total_size_under_10_mb():
    assert sum(p.stat().st_size for p in SAMPLES.iterdir()) < 10 * 1024 * 1024


# ---------------------------------------------------------------- env maps


@pytest.mark.parametrize("name", ["sky_sun.exr", "studio.exr", "white.exr"])
def test_envmap_finite_rgb_and_integrals_match_sidecar(name, info):
    img = read_exr(SAMPLES / name).astype(np.float64)
    h, w, c = img.shape
    assert c == 3 and w == 2 * h and [w, h] == info[name]["size"]
    assert np.isfinite(img).all() and (img >= 0).all()
    dw = latlong_solid_angles(h, w)[..., None]
    np.testing.assert_allclose((img * dw).sum((0, 1)), info[name]["power_rgb"], rtol=1e-7)
    # irradiance at normal +Y: cos-weighted, by fine quadrature within each texel row
    sub = 64
    t = np.pi * (np.arange(h * sub) + 0.5) / (h * sub)
    wcos = (np.clip(np.cos(t), 0, None) * np.sin(t) * (np.pi / (h * sub))).reshape(h, sub).sum(1)
    e_up = (img.sum(1) * wcos[:, None] * (2 * np.pi / w)).sum(0)
    np.testing.assert_allclose(e_up, info[name]["irradiance_up_rgb"], rtol=1e-3)


def test_white_furnace_integrals(info):
    white = info["white.exr"]
    np.testing.assert_allclose(white["power_rgb"], 4 * np.pi, rtol=1e-7)
    np.testing.assert_allclose(white["irradiance_up_rgb"], np.pi, rtol=1e-7)


def test_sun_power_direction_and_dominance(info):
    img = read_exr(SAMPLES / "sky_sun.exr").astype(np.float64)
    h, w, _ = img.shape
    sun = info["sky_sun.exr"]["sun"]
    el, ph = np.radians(sun["elevation_deg"]), np.radians(sun["phi_deg"])
    s = np.array([np.cos(el) * np.sin(ph), np.sin(el), -np.cos(el) * np.cos(ph)])
    np.testing.assert_allclose(sun["direction"], s, atol=1e-8)
    r = np.radians(sun["angular_radius_deg"])
    analytic = np.asarray(sun["radiance_rgb"]) * 2 * np.pi * (1 - np.cos(r))
    ang = np.degrees(np.arccos(np.clip(latlong_centre_dirs(h, w) @ s, -1, 1)))
    dw = latlong_solid_angles(h, w)
    window = ang < 3.0
    ring = (ang > 3.0) & (ang < 5.0)
    bg = (img[ring] * dw[ring, None]).sum(0) / dw[ring].sum()  # local sky level
    excess = ((img[window] - bg) * dw[window, None]).sum(0)
    np.testing.assert_allclose(excess, analytic, rtol=0.02)
    # the sun's brightest texels sit where the conventions' mapping puts direction s
    wts = (img[window] - bg).sum(1) * dw[window]
    centroid = (latlong_centre_dirs(h, w)[window] * wts[:, None]).sum(0)
    assert np.degrees(np.arccos(centroid @ s / np.linalg.norm(centroid))) < 0.1
    # the sun dominates the irradiance of an upward-facing surface
    sun_e_up = analytic * s[1]
    assert (sun_e_up > 0.75 * np.asarray(info["sky_sun.exr"]["irradiance_up_rgb"])).all()


def test_studio_power_matches_softbox_solid_angles(info):
    studio = info["studio.exr"]
    analytic = 4 * np.pi * np.asarray(studio["background"]["rgb"])
    for box in studio["softboxes"]:
        a = np.tan(np.radians(box["half_width_deg"]))
        b = np.tan(np.radians(box["half_height_deg"]))
        omega = 4 * np.arctan(a * b / np.sqrt(1 + a * a + b * b))
        analytic = analytic + omega * np.asarray(box["radiance_rgb"])
        np.testing.assert_allclose(box["power_supersampled_rgb"], box["power_rgb"], rtol=0.01)
    np.testing.assert_allclose(studio["power_rgb"], analytic, rtol=0.01)


# ---------------------------------------------------------------- meshes


@pytest.mark.parametrize("name", ["sphere.obj", "teapot.obj", "floor.obj"])
def test_mesh_loads_with_unit_outward_normals(name):
    trimesh = pytest.importorskip("trimesh")
    v, vt, vn, f = read_obj(SAMPLES / name)
    mesh = trimesh.load(SAMPLES / name, process=False)  # force="mesh" would need Pillow
    assert isinstance(mesh, trimesh.Trimesh)
    assert mesh.vertices.shape == v.shape and mesh.faces.shape == f.shape
    assert np.isfinite(v).all() and np.isfinite(vn).all() and len(vn) == len(v)
    np.testing.assert_allclose(np.linalg.norm(vn, axis=1), 1.0, atol=2e-6)
    assert mesh.is_winding_consistent
    area = mesh.area_faces > 1e-12
    agree = np.einsum("ij,ij->i", mesh.face_normals[area], vn[f[area]].mean(1))
    assert agree.min() > 0.5 and agree.mean() > 0.99
    if vt is not None:
        assert len(vt) == len(v) and (vt >= 0).all() and (vt <= 1).all()


def test_sphere_geometry():
    v, vt, vn, f = read_obj(SAMPLES / "sphere.obj")
    assert 2000 <= len(v) <= 5000
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=2e-6)
    np.testing.assert_allclose(vn, v, atol=2e-6)
    # vt follows the lat-long map: u = phi / 2 pi, v = 1 - theta / pi (away from the poles)
    mid = np.abs(v[:, 1]) < 0.99
    theta = np.arccos(np.clip(v[mid, 1], -1, 1))
    np.testing.assert_allclose(1 - vt[mid, 1], theta / np.pi, atol=1e-5)
    phi = 2 * np.pi * vt[mid, 0]
    d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], -1)
    np.testing.assert_allclose(d, v[mid], atol=1e-5)


def test_teapot_closed_ish_outward_and_sized():
    trimesh = pytest.importorskip("trimesh")
    v, _, vn, f = read_obj(SAMPLES / "teapot.obj")
    mesh = trimesh.Trimesh(v, f, process=False)
    assert 8000 <= len(v) <= 12000
    assert mesh.volume > 0.5  # signed, divergence theorem: outward winding
    assert abs(v[:, 1].min()) < 1e-6
    top = v[:, 1].max()
    assert np.linalg.norm(v - [0, top / 2, 0], axis=1).max() <= 1.0 + 1e-6
    # closed-ish: few boundary edges (lid gap, spout tip, handle/spout ends)
    edges = np.sort(mesh.edges, axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 1).sum() < 0.03 * len(counts) and (counts <= 2).all()
    # poles: lid knob top faces up, bottom centre faces down
    np.testing.assert_allclose(vn[np.argmax(v[:, 1])], [0, 1, 0], atol=1e-6)
    np.testing.assert_allclose(vn[np.argmin(v[:, 1])], [0, -1, 0], atol=1e-6)
    # every part outward: a ray leaving along the normal seldom re-enters its own part,
    # a ray leaving against it almost always hits the part's far wall (tubes) or the body
    parts = trimesh.graph.connected_components(mesh.face_adjacency, nodes=np.arange(len(f)))
    assert len(parts) == 4  # body (rim, body, bottom), lid, handle, spout
    for faces in parts:
        part = mesh.submesh([np.sort(faces)], append=True)
        c, n = part.triangles_center, part.face_normals
        out = part.ray.intersects_any(c + 1e-5 * n, n).mean()
        inward = part.ray.intersects_any(c - 1e-5 * n, -n).mean()
        assert out < inward and out < 0.25, (len(part.faces), out, inward)


def test_floor_plane():
    v, vt, vn, f = read_obj(SAMPLES / "floor.obj")
    assert 8000 <= len(v) <= 12000
    assert np.abs(v[:, 1]).max() == 0 and np.allclose(vn, [0, 1, 0])
    np.testing.assert_allclose([v[:, 0].min(), v[:, 0].max(), v[:, 2].min(), v[:, 2].max()],
                               [-3, 3, -3, 3])
    e1, e2 = v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]
    cross = np.cross(e1, e2)
    assert (cross[:, 1] > 0).all()
    np.testing.assert_allclose(0.5 * cross[:, 1].sum(), 36.0, rtol=1e-9)
    np.testing.assert_allclose(vt, np.stack([(v[:, 0] + 3) / 6, (3 - v[:, 2]) / 6], 1), atol=1e-6)


# ---------------------------------------------------------------- normal map


def test_normal_map_unit_z_up_and_consistent_with_height():
    png = read_exr(SAMPLES / "normal_map.png", channels=(3,)).astype(np.float64) * 2 - 1
    exr = read_exr(SAMPLES / "normal_map.exr", channels=(3,)).astype(np.float64) * 2 - 1
    h = read_exr(SAMPLES / "bump_height.exr", channels=(1,))[..., 0].astype(np.float64)
    res = h.shape[0]
    assert png.shape == exr.shape == (res, res, 3)
    assert (png[..., 2] > 0).all()
    np.testing.assert_allclose(np.linalg.norm(png, axis=-1), 1.0, atol=0.015)
    np.testing.assert_allclose(np.linalg.norm(exr, axis=-1), 1.0, atol=2e-3)
    np.testing.assert_allclose(png, exr, atol=2.5 / 255)
    # periodic 4th-order central differences; row 0 is v = 1, so +v is toward row - 1
    def d(axis, sign):
        f = lambda k: np.roll(h, -sign * k, axis)  # noqa: E731  value k texels toward +
        return (8 * (f(1) - f(-1)) - (f(2) - f(-2))) * res / 12
    hu, hv = d(1, 1), d(0, -1)
    fd = np.stack([-hu, -hv, np.ones_like(h)], -1)
    fd /= np.linalg.norm(fd, axis=-1, keepdims=True)
    cos = np.clip((fd * exr).sum(-1) / np.linalg.norm(exr, axis=-1), -1, 1)
    err = np.degrees(np.arccos(cos))
    assert np.percentile(err, 99) < 1.0 and err.max() < 2.0  # FD error at the bump rims (C1)


def test_textured_ball_is_what_it_claims():
    """textured_ball.glb reads back through sgpipe's glTF reader: one primitive, the sphere's
    vertices, roughness 0.05 → 0.8 along u, metalness 0/1 bands with sharp edges along v."""
    from sgpipe.io.gltf import primitive_geometry, read_gltf
    from sgpipe.io.gltf_textures import material_texture
    a = read_gltf(SAMPLES / "textured_ball.glb")
    (ref,) = a.primitives
    geo = primitive_geometry(a, ref)
    np.testing.assert_allclose(np.linalg.norm(geo["positions"], axis=1), 1.0, atol=2e-6)
    mr = material_texture(a, ref.material, "metallicRoughnessTexture").image
    rough = mr[0, :, 1]
    assert abs(rough[0] - 0.05) < 0.01 and abs(rough[-1] - 0.8) < 0.01
    assert np.all(np.diff(rough) >= 0)
    metal = mr[:, 0, 2]
    assert set(np.unique(metal)) == {0.0, 1.0}
    assert np.count_nonzero(np.diff(metal)) == 3           # three sharp edges down the rows
    assert material_texture(a, ref.material, "baseColorTexture").image.shape == (128, 256, 3)
    assert material_texture(a, ref.material, "normalTexture") is not None
