"""Fuzzing the config loader and the file readers (hypothesis): whatever the bytes, the
outcome is a value or one BadInput naming the file, never another exception. Bounded for CI
(SGPIPE_FUZZ_EXAMPLES examples per target, default 60); set it higher for a longer pass."""

import os
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sgpipe.config import load_config
from sgpipe.errors import BadInput

EXAMPLES = int(os.environ.get("SGPIPE_FUZZ_EXAMPLES", "60"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
                suppress_health_check=list(HealthCheck))

# keys and values real configs use, so that the fuzzer reaches the schema, not only the parser
KEYS = ["name", "seed", "workers", "scene", "objects", "mesh", "sphere_radius", "material",
        "translate", "scale", "fit", "materials", "model", "params", "alpha", "kd", "ks",
        "envmap", "environment", "cube_resolution", "visibility", "trace_resolution",
        "resolution", "pca_terms", "render", "camera", "width", "height", "eye", "methods",
        "spp", "lights", "type", "position", "intensity", "transport", "normalmap", "&a", "*a"]
SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-2 ** 70, 2 ** 70),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
                    st.sampled_from(["ggx", "sg", "lambert", "[1, 2, 3]", "1e400", "-0",
                                     "~", "{", "*a", "&a x", "!!binary AAA"]))
TREES = st.recursive(SCALARS, lambda kids: st.one_of(
    st.lists(kids, max_size=4), st.dictionaries(st.sampled_from(KEYS), kids, max_size=5)),
    max_leaves=25)


def _load(text: str):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "c.yaml"
        p.write_text(text, encoding="utf-8", errors="surrogatepass")
        try:
            load_config(p)
        except BadInput as e:
            assert e.one_line(), "an empty message"


def _dump(tree) -> str:
    import yaml
    try:
        return yaml.safe_dump(tree, allow_unicode=True)
    except (yaml.YAMLError, UnicodeEncodeError):
        return ""


@FUZZ
@given(st.text(max_size=300))
def test_config_loader_on_any_text(text):
    _load(text)


@FUZZ
@given(st.dictionaries(st.sampled_from(KEYS), TREES, max_size=6))
def test_config_loader_on_config_shaped_trees(tree):
    _load(_dump(tree))


@FUZZ
@given(st.lists(st.sampled_from(
    ["name: x\n", "scene:\n", "  objects:\n", "    - {name: a, sphere_radius: 1}\n",
     "render:\n", "  camera: &c {width: 8, height: 8}\n", "  spp: *c\n", "fit:\n",
     "  materials:\n", "    - {name: m, model: ggx, params: {alpha: 0}}\n", "seed: 1\n",
     "seed: 2\n", "x: &x [*x]\n", "  <<: *c\n", "\t\n", "envmap: {}\n"]), max_size=10))
def test_config_loader_on_recombined_lines(lines):
    _load("".join(lines))


def _read(suffix: str, data: bytes, reader):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"f{suffix}"
        p.write_bytes(data)
        try:
            reader(p)
        except BadInput as e:
            assert str(p) in e.one_line()


def _read_exr(p):
    from sgpipe.io import read_exr
    read_exr(p, channels=(3, 4), key="envmap.environment")


def _read_png(p):
    from sgpipe.io import read_data_image
    read_data_image(p, key="normal_map")


def _read_obj(p):
    from sgpipe.io.mesh import _read_mesh_file
    _read_mesh_file(p, "scene.objects.0.mesh")


def _read_glb(p):
    from sgpipe.io.mesh import _read_gltf_primitives
    _read_gltf_primitives(p, None, None, "scene.objects.0.mesh")


def _valid(kind: str) -> bytes:
    """A small valid file of `kind`, for mutation."""
    with tempfile.TemporaryDirectory() as d:
        if kind == "obj":
            return b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\n"
        if kind in ("glb", "gltf"):
            import sys
            sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scene"))
            import gltf_builder
            if kind == "glb":
                return gltf_builder.write_glb(gltf_builder.build(), Path(d) / "v.glb") \
                    .read_bytes()
            return gltf_builder.write_gltf_embedded(gltf_builder.build(), Path(d) / "v.gltf") \
                .read_bytes()
        p = Path(d) / f"v.{kind}"
        img = np.linspace(0, 1, 4 * 8 * 3, dtype=np.float32).reshape(4, 8, 3)
        if kind == "exr":
            from sgpipe.io import write_exr
            write_exr(p, img)
        else:
            from sgpipe.io import write_png
            write_png(p, img)
        return p.read_bytes()


def _mutations(kind: str):
    base = _valid(kind)
    return st.one_of(
        st.binary(max_size=400),
        st.builds(lambda n: base[:n], st.integers(0, len(base))),
        st.builds(lambda i, b: base[:i] + bytes([b]) + base[i + 1:],
                  st.integers(0, len(base) - 1), st.integers(0, 255)))


@FUZZ
@given(_mutations("exr"))
def test_exr_reader_on_damaged_files(data):
    _read(".exr", data, _read_exr)


@FUZZ
@given(_mutations("png"))
def test_png_reader_on_damaged_files(data):
    _read(".png", data, _read_png)


@FUZZ
@given(_mutations("obj"))
def test_obj_reader_on_damaged_files(data):
    _read(".obj", data, _read_obj)


@FUZZ
@given(_mutations("glb"))
def test_glb_reader_on_damaged_files(data):
    _read(".glb", data, _read_glb)


@FUZZ
@given(_mutations("gltf"))
def test_gltf_reader_on_damaged_files(data):
    _read(".gltf", data, _read_glb)
