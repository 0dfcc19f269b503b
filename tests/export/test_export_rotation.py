"""render.environment_rotation in `sgpipe export`: SH9 of the turned environment against the
projection of the turned map, the glTF light's quaternion against R under glTF's convention,
cubemaps left in map space, and no rotation → the same bytes as an export without it. These
tests export in sgpipe's own orientation (the rotation alone); the last one adds the glTF
orientation's quarter turn."""

import json
import shutil

import numpy as np
import pygltflib as gl
import pytest
import yaml

from sgpipe.core.maps import cubemap_texel_dirs
from sgpipe.core.quadrature import hemisphere_quadrature
from sgpipe.core.rotation import quat_rotate, quat_to_matrix, rotation_matrix
from sgpipe.envmap import lightfit
from sgpipe.errors import BadInput
from sgpipe.export import sh9
from sgpipe.export.bundle import write_export
from sgpipe.export.env_rotation import gltf_quaternion
from sgpipe.export.orientation import GLTF_TO_MAP

from .test_prefilter import spot_radiance

AXIS, ANGLE = [0.3, 1.0, -0.2], 37.0


def _with_rotation(src, dst, rotation, stage="envmap"):
    """A copy of the run folder whose `<stage>/config.resolved.yaml` has `rotation` (None: a
    render section without the key)."""
    shutil.copytree(src, dst)
    render = {"methods": ["sg"]}
    if rotation is not None:
        render["environment_rotation"] = rotation
    (dst / stage).mkdir(exist_ok=True)
    (dst / stage / "config.resolved.yaml").write_text(yaml.safe_dump({"render": render}))
    return dst


@pytest.fixture(scope="module")
def turned(tiny_run, tmp_path_factory):
    root = tmp_path_factory.mktemp("rot")
    run = _with_rotation(tiny_run["dir"], root / "run", {"axis": AXIS, "angle_deg": ANGLE})
    return write_export(run, root / "export", orientation="sgpipe")


def test_sh9_is_the_projection_of_the_turned_map(tiny_run, turned):
    """The map turned by R (texel at d shows L(Rᵀd)), sampled and projected as the envmap stage
    projects a map: its SH9 equals the exported coefficients; E(n) from them follows
    quadrature of the turned continuous map within the order-2 truncation (as unturned)."""
    R = rotation_matrix(AXIS, ANGLE)
    doc = json.loads((turned / "irradiance_sh9.json").read_text())
    irr, rad = np.array(doc["irradiance"]), np.array(doc["radiance"])
    n = tiny_run["cube"].shape[1]
    cube_turned = spot_radiance(cubemap_texel_dirs(n) @ R)       # rows d @ R = Rᵀd
    ref = lightfit.sh_light(cube_turned, 2)
    scale = np.abs(ref["irradiance_coeffs"][0]).max()
    # both sample the map at 32² texel centres, turned or not: the difference is that sampling
    np.testing.assert_allclose(irr, ref["irradiance_coeffs"][:9], atol=2e-3 * scale)
    np.testing.assert_allclose(rad, ref["coeffs"][:9], atol=2e-3 * scale / np.pi)
    unturned = np.array(doc["map_irradiance"])
    assert np.abs(irr - unturned).max() > 0.05 * scale          # it did turn
    # band by band a rotation keeps the energy
    for lo, hi in ((0, 1), (1, 4), (4, 9)):
        np.testing.assert_allclose(np.linalg.norm(irr[lo:hi], axis=0),
                                   np.linalg.norm(unturned[lo:hi], axis=0), rtol=1e-12)
    ns = np.random.default_rng(3).normal(size=(16, 3))
    ns /= np.linalg.norm(ns, axis=1, keepdims=True)
    # E'(n) = E(Rᵀn): the turned coefficients are the unturned irradiance looked up turned back
    np.testing.assert_allclose(sh9.sh9_irradiance(irr, ns), sh9.sh9_irradiance(unturned, ns @ R),
                               rtol=1e-12, atol=1e-12 * scale)
    # against quadrature of the turned continuous map: the order-2 truncation error, the same
    # at n as the unturned map's at Rᵀn (measured ≤ 4.3 % of the mean on this 32² map)
    e_ref = []
    for nn in ns:
        d, w = hemisphere_quadrature(64, 128, axis=nn)
        e_ref.append(((d @ nn) * w) @ spot_radiance(d @ R))
    e_ref = np.array(e_ref)
    err = (sh9.sh9_irradiance(irr, ns) - e_ref) / e_ref.mean(0)
    assert np.abs(err).max() < 0.05
    e_back = []
    for nn in ns @ R:
        d, w = hemisphere_quadrature(64, 128, axis=nn)
        e_back.append(((d @ nn) * w) @ spot_radiance(d))
    np.testing.assert_allclose(e_ref, e_back, rtol=1e-6)
    assert doc["environment_rotation"]["angle_deg"] == ANGLE
    np.testing.assert_array_equal(doc["environment_rotation"]["matrix"], R)


def test_gltf_light_rotation_turns_d_to_R_d(tiny_run, turned):
    """glTF quaternions are [x, y, z, w] (scalar last) and rotate like a node's `rotation`:
    the map's direction d goes to R·d; the light's SH stay in map space (the runtime turns them
    with its images, as Babylon.js evaluates them at reflectionMatrix·n)."""
    R = rotation_matrix(AXIS, ANGLE)
    doc = gl.GLTF2().load(str(turned / "scene.gltf"))
    light = doc.extensions["EXT_lights_image_based"]["lights"][0]
    q = np.array(light["rotation"])
    assert q.shape == (4,) and abs(np.linalg.norm(q) - 1) < 1e-12 and q[3] >= 0
    d = np.random.default_rng(1).normal(size=(50, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    np.testing.assert_allclose(quat_rotate(q, d), d @ R.T, atol=1e-12)
    np.testing.assert_allclose(quat_to_matrix(q), R, atol=1e-12)
    sh = json.loads((turned / "irradiance_sh9.json").read_text())
    np.testing.assert_allclose(light["irradianceCoefficients"], sh["map_irradiance"], rtol=0,
                               atol=0)
    np.testing.assert_allclose(light["extras"]["sgpipe_world_irradiance"], sh["irradiance"],
                               rtol=1e-15, atol=1e-15)


def test_quarter_turn_quaternion_by_hand():
    """90° about +Y: q = (0, sin 45°, 0, cos 45°) and the map's −Z (u = 0) appears at −X."""
    q = gltf_quaternion(rotation_matrix([0, 1, 0], 90))
    np.testing.assert_allclose(q, [0, np.sqrt(0.5), 0, np.sqrt(0.5)], atol=1e-15)
    np.testing.assert_allclose(quat_rotate(q, [0, 0, -1]), [-1, 0, 0], atol=1e-15)
    q = gltf_quaternion(rotation_matrix([1, 0, 0], 180))            # w = 0: sign fixed
    np.testing.assert_allclose(q, [1, 0, 0, 0], atol=1e-15)


def _files(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_no_rotation_is_byte_identical(tiny_run, turned, tmp_path):
    """No config, a render section without the key, or angle 0: the same bytes; a turn changes
    the glTF, SH9 JSON and export.json only (the cubemaps stay in map space)."""
    plain = _files(write_export(tiny_run["dir"], tmp_path / "plain", orientation="sgpipe"))
    for i, rot in enumerate((None, {"axis": [0, 1, 0], "angle_deg": 0.0})):
        run = _with_rotation(tiny_run["dir"], tmp_path / f"run{i}", rot, stage="render")
        assert _files(write_export(run, tmp_path / f"out{i}", orientation="sgpipe")) == plain
    changed = {k for k, v in _files(turned).items() if plain.get(k) != v}
    assert changed == {"scene.gltf", "irradiance_sh9.json", "export.json"}
    info = json.loads((turned / "export.json").read_text())
    assert info["environment_rotation"]["config"] == "envmap/config.resolved.yaml"
    assert "envmap/config.resolved.yaml" in info["run_dir_inputs"]


def test_render_config_wins_over_envmap(tiny_run, tmp_path):
    """The render stage's config (the rotation its images used) is read before the envmap's."""
    run = _with_rotation(tiny_run["dir"], tmp_path / "run", {"axis": AXIS, "angle_deg": ANGLE})
    (run / "render").mkdir()
    (run / "render" / "config.resolved.yaml").write_text(yaml.safe_dump(
        {"render": {"environment_rotation": {"axis": [0, 1, 0], "angle_deg": 90}}}))
    out = write_export(run, tmp_path / "out", orientation="sgpipe")
    doc = gl.GLTF2().load(str(out / "scene.gltf"))
    q = doc.extensions["EXT_lights_image_based"]["lights"][0]["rotation"]
    np.testing.assert_allclose(q, [0, np.sqrt(0.5), 0, np.sqrt(0.5)], atol=1e-15)


@pytest.mark.parametrize("rot, match", [({"axis": [0, 0, 0], "angle_deg": 10}, "non-zero"),
                                        ({"axis": [0, 1], "angle_deg": 10}, "3 numbers"),
                                        ({"angle_deg": 10}, "axis"),
                                        ({"axis": [0, 1, 0], "angle_deg": 400}, "360")])
def test_bad_rotation_is_bad_input(tiny_run, tmp_path, rot, match):
    run = _with_rotation(tiny_run["dir"], tmp_path / "run", rot)
    with pytest.raises(BadInput, match=match) as e:
        write_export(run, tmp_path / "out", orientation="sgpipe")
    assert e.value.key == "render.environment_rotation"
    assert str(e.value.file).endswith("envmap/config.resolved.yaml")
    assert not (tmp_path / "out").exists()


def test_gltf_orientation_composes_with_the_rotation(tiny_run, tmp_path):
    """Default (glTF) orientation and a rotation R: the light turns the cube's e to R·M·e (the
    world direction that shows it), its irradiance is the map's read at M·e, and its world
    irradiance is irradiance_sh9.json's; the cubemaps are those of the unturned glTF export."""
    run = _with_rotation(tiny_run["dir"], tmp_path / "run", {"axis": AXIS, "angle_deg": ANGLE})
    out = write_export(run, tmp_path / "out")
    plain = write_export(tiny_run["dir"], tmp_path / "plain")
    for name in ("environment.ktx2", "environment.dds"):
        assert (out / name).read_bytes() == (plain / name).read_bytes()
    R = rotation_matrix(AXIS, ANGLE)
    light = gl.GLTF2().load(str(out / "scene.gltf")).extensions[
        "EXT_lights_image_based"]["lights"][0]
    e = np.random.default_rng(5).normal(size=(50, 3))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    np.testing.assert_allclose(quat_rotate(light["rotation"], e), e @ (R @ GLTF_TO_MAP).T,
                               atol=1e-12)
    sh = json.loads((out / "irradiance_sh9.json").read_text())
    np.testing.assert_allclose(sh9.sh9_irradiance(light["irradianceCoefficients"], e),
                               sh9.sh9_irradiance(sh["map_irradiance"], e @ GLTF_TO_MAP.T),
                               rtol=1e-10)
    np.testing.assert_allclose(light["extras"]["sgpipe_world_irradiance"], sh["irradiance"],
                               rtol=1e-10, atol=1e-12)
