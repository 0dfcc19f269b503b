"""Per-vertex materials of the transport stage (transport.vertex_materials): a textured
gltf_pbr quad whose halves are two materials, subdivided so that each half has vertices of its
own; the textures filtered to the vertex spacing, each vertex's transport fitted with its own
BRDF and rendered by the Green06 methods."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scene"))
import gltf_builder as gb  # noqa: E402

#: cells per side of the subdivided quad: 1/8 of the uv square, 4 texels of the 32² halves
CELLS = 8


def grid_quad(images: dict, *, cells: int = CELLS, **material):
    """The 2 × 2 quad of gltf_builder.textured_quad (facing +z, glTF uv (0, 0) at its top-left
    corner) as cells × cells squares."""
    s = np.linspace(0.0, 1.0, cells + 1)
    u, v = np.meshgrid(s, s)                      # v: glTF's, 0 at the top (y = 1)
    p = np.stack([2 * u - 1, 1 - 2 * v, np.zeros_like(u)], -1).reshape(-1, 3)
    n = np.tile([0.0, 0.0, 1.0], (len(p), 1))
    k = np.arange(cells + 1)
    a = (k[:-1, None] * (cells + 1) + k[None, :-1]).ravel()      # top-left of each cell
    b, c, d = a + 1, a + cells + 2, a + cells + 1                  # top-right, bottom-...
    idx = np.stack([a, d, c, a, c, b], 1).ravel()                  # counter-clockwise from +z
    return gb.primitive_doc(p, n, np.stack([u, v], -1).reshape(-1, 2), idx, images,
                            wrap=33071, **material)


def halves_grids(folder: Path):
    """(textured grid .glb, {"a": uniform grid of the left half's material, "b": right's})."""
    from sgpipe.io.png import srgb_to_linear
    mr = gb.halves([0, 0.3, 0.0], [0, 0.7, 1.0])
    tex = gb.write_glb(grid_quad({"baseColorTexture": gb.halves(gb.HALF_A, gb.HALF_B),
                                  "metallicRoughnessTexture": mr}), folder / "tex.glb")
    uniform = {}
    for tag, (col, r, m) in gb.HALF_MATERIALS.items():
        lin = srgb_to_linear(np.round(col * 255) / 255)          # the PNG's 8 bits
        uniform[tag] = gb.write_glb(grid_quad({}, base=tuple(lin), metallic=m,
                                              roughness=np.round(r * 255) / 255),
                                    folder / f"{tag}.glb")
    return tex, uniform


def _found_and_geometry(glb: Path):
    """render.setup.gltf_textures' tuple and the mesh of the file's one primitive."""
    from sgpipe.config import load_config
    from sgpipe.io.mesh import load_scene
    from sgpipe.render.setup import gltf_textures
    cfg_path = glb.with_suffix(".yaml")
    cfg_path.write_text(f"scene: {{gltf: [{{file: {glb}}}]}}\n")
    cfg = load_config(cfg_path)
    return gltf_textures(cfg, cfg.scene.objects[0], {}), load_scene(cfg.scene)[0]


def test_vertex_materials_are_the_halves_filtered_to_the_vertex_spacing(tmp_path):
    """On the 8 × 8 grid (edges of 4 texels) the vertices a box of one edge keeps inside a
    half take that half's material (F0, roughness at 8 bits); the seam's vertices lie between;
    on the plain 2-triangle quad (edges of 32 texels, the whole image) every vertex takes the
    image's mean: ln roughness averaged, F0 linearly."""
    from sgpipe.io.png import srgb_to_linear
    from sgpipe.transport.vertex_material import vertex_materials
    tex, _ = halves_grids(tmp_path)
    found, geom = _found_and_geometry(tex)
    vm = vertex_materials(found, geom)
    u = geom.uvs[:, 0]
    f0_b = srgb_to_linear(np.round(gb.HALF_B * 255) / 255)
    r_a, r_b = np.round(0.3 * 255) / 255, np.round(0.7 * 255) / 255
    left, right, seam = u < 0.4, u > 0.6, np.isclose(u, 0.5)
    np.testing.assert_allclose(vm.f0[left], 0.04, atol=1e-6)
    np.testing.assert_allclose(vm.roughness[left], r_a, rtol=1e-5)
    np.testing.assert_allclose(vm.f0[right], np.broadcast_to(f0_b, (right.sum(), 3)),
                               atol=1e-6)
    np.testing.assert_allclose(vm.roughness[right], r_b, rtol=1e-5)
    assert (vm.roughness[seam] > r_a + 0.05).all() and (vm.roughness[seam] < r_b - 0.05).all()
    coarse = tmp_path / "coarse"
    coarse.mkdir()
    mr = gb.halves([0, 0.3, 0.0], [0, 0.7, 1.0])
    glb = gb.write_glb(grid_quad({"baseColorTexture": gb.halves(gb.HALF_A, gb.HALF_B),
                                  "metallicRoughnessTexture": mr}, cells=1),
                       coarse / "q.glb")
    vm1 = vertex_materials(*_found_and_geometry(glb))
    np.testing.assert_allclose(vm1.roughness, np.sqrt(r_a * r_b), rtol=1e-5)
    np.testing.assert_allclose(vm1.f0, np.broadcast_to(0.5 * (0.04 + f0_b), (4, 3)), atol=1e-6)


def test_untextured_and_anisotropic_materials_keep_their_factors(tmp_path):
    """No texture, or KHR_materials_anisotropy: no per-vertex materials (the factors' fit)."""
    from sgpipe.transport.vertex_material import vertex_materials
    _, uniform = halves_grids(tmp_path)
    assert vertex_materials(*_found_and_geometry(uniform["a"])) is None
    doc = gb.add_anisotropy(grid_quad({"baseColorTexture": gb.halves(gb.HALF_A, gb.HALF_B)}),
                            0.5)
    glb = gb.write_glb(doc, tmp_path / "aniso.glb")
    assert vertex_materials(*_found_and_geometry(glb)) is None


SECTIONS = ("visibility: {trace_resolution: 16, resolution: 8, pca_terms: 4}\n"
            "transport: {cube_resolution: 8, report_vertices: 0%s}\n")
FIT = "{view_gmm: {enabled: false}, ndf_sg: {report_lobes: 0}}"


@pytest.mark.parametrize("method", ["transport_green06"])
def test_per_vertex_fit_renders_each_half_as_its_uniform_material(tmp_path, method):
    """`transport_green06`'s glossy part is the stage's Gaussians (under the studio map): with
    per-vertex materials each half of the textured grid renders as the uniform grid of its
    material within 3 % away from the seam; fitted for the factors (white rough metal,
    transport.vertex_materials: false) both halves are more than 20 % off. The vertex
    material file holds the halves' parameters."""
    from sgpipe.artifacts.transport import read_vertex_materials
    tex, uniform = halves_grids(tmp_path)

    def render(glb, tag, extra=""):
        return gb.render_quad(tmp_path, glb, tag, (method,), fit=FIT,
                              sections=SECTIONS % extra)[method]
    img = render(tex, "tex")
    plain = render(tex, "factors", ", vertex_materials: false")
    half = {tag: render(glb, tag) for tag, glb in uniform.items()}
    vm = read_vertex_materials(tmp_path / "out_tex" / "transport", "tex.quad.0")
    assert vm is not None and vm["roughness"].shape == ((CELLS + 1) ** 2,)
    assert read_vertex_materials(tmp_path / "out_factors" / "transport", "tex.quad.0") is None
    cols = np.arange(32)
    rows = slice(6, 26)
    for sel, tag in ((cols < 10, "a"), (cols > 21, "b")):
        want = half[tag][rows][:, sel]
        assert np.abs(want).max() > 0.02

        def err(a):
            return np.abs(a[rows][:, sel] - want).mean() / np.abs(want).mean()
        assert err(img) <= 0.03, (tag, err(img))
        assert err(plain) >= 0.2, (tag, err(plain))


STAGE = """
name: vm
seed: 1
workers: {workers}
scene: {{gltf: [{{file: {glb}}}]}}
transport: {{cube_resolution: 4, lobe_samples: 16, chunk_vertices: 16, report_vertices: 0,
             vertex_materials: {vm}}}
"""


def _stage(tmp_path, glb, tag, *, workers=1, vm="true"):
    from sgpipe.config import load_config
    from sgpipe.stages import transport as stage
    cfg = tmp_path / f"{tag}.yaml"
    cfg.write_text(STAGE.format(workers=workers, glb=glb, vm=vm))
    out = tmp_path / tag
    stage.run(load_config(cfg), out)
    obj = f"{glb.stem}.quad.0"
    return {p.name: p.read_bytes() for p in sorted((out / "transport" / obj).glob("*.npz"))}


def test_per_vertex_stage_is_deterministic_and_untextured_objects_are_unchanged(tmp_path):
    """The textured grid's artifacts (vertex_material.npz included) are the same bytes for 1
    and 2 workers over 16-vertex chunks and differ from the factors' fit only in the
    Gaussians; an untextured material's artifacts are the same bytes with per-vertex materials
    on and off (no vertex_material.npz)."""
    from sgpipe.artifacts.transport import GAUSSIANS, VERTEX_MATERIALS
    tex, uniform = halves_grids(tmp_path)
    one = _stage(tmp_path, tex, "w1")
    assert one == _stage(tmp_path, tex, "w2", workers=2)
    plain = _stage(tmp_path, tex, "factors", vm="false")
    assert VERTEX_MATERIALS in one and VERTEX_MATERIALS not in plain
    assert one[GAUSSIANS] != plain[GAUSSIANS]
    assert {k: v for k, v in one.items() if k not in (GAUSSIANS, VERTEX_MATERIALS)} == \
        {k: v for k, v in plain.items() if k != GAUSSIANS}
    on = _stage(tmp_path, uniform["a"], "a_on")
    assert on == _stage(tmp_path, uniform["a"], "a_off", vm="false")
    assert VERTEX_MATERIALS not in on


def test_missing_texture_is_bad_input_and_nothing_is_written(tmp_path):
    """A textured object whose image is missing: one BadInput naming the image, no artifacts."""
    from sgpipe.config import load_config
    from sgpipe.errors import BadInput
    from sgpipe.stages import transport as stage
    doc = grid_quad({"baseColorTexture": gb.halves(gb.HALF_A, gb.HALF_B)})
    doc.images[0].bufferView = None
    doc.images[0].uri = "missing.png"
    glb = gb.write_glb(doc, tmp_path / "q.glb")
    cfg = tmp_path / "c.yaml"
    cfg.write_text(STAGE.format(workers=1, glb=glb, vm="true"))
    with pytest.raises(BadInput) as e:
        stage.run(load_config(cfg), tmp_path / "out")
    assert e.value.key == "images[0]" and "missing.png" in e.value.message
    assert not (tmp_path / "out" / "transport").exists()
