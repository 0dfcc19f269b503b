"""Config: safe_load, typed validation with key paths and lines, overrides, relative paths."""

import textwrap
from dataclasses import fields, is_dataclass
from pathlib import Path

import pytest
import yaml

from sgpipe.config import load_config, to_plain
from sgpipe.config.root import Config
from sgpipe.config.schema import describe
from sgpipe.errors import BadInput


def write(tmp_path, text, name="c.yaml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def test_defaults_are_explicit_and_documented():
    def walk(cls):
        for f in fields(cls):
            if f.metadata.get("internal"):
                continue
            assert f.metadata.get("doc"), f"{cls.__name__}.{f.name} has no doc"
            for t in getattr(f.type, "__args__", ()):
                if is_dataclass(t):
                    walk(t)
    walk(Config)
    assert any("fov_deg" in ln for ln in describe(Config))


def test_empty_config_is_valid(tmp_path):
    cfg = load_config(write(tmp_path, "name: x\n"))
    assert cfg.name == "x" and cfg.seed == 0 and cfg.render is None


@pytest.mark.parametrize("text,key,line,msg", [
    ("name: x\nbogus: 1\n", "bogus", 2, "unknown key"),
    ("seed: -1\n", "seed", 1, "must be >= 0"),
    ("seed: 1.5\n", "seed", 1, "expected an integer"),
    ("seed: true\n", "seed", 1, "expected an integer"),
    ("seed: 18446744073709551617\n", "seed", 1, "must be <= 9223372036854775807"),
    ("workers: 100000\n", "workers", 1, "must be <= 512"),
    ("render:\n  camera:\n    width: 1000000000\n", "render.camera.width", 3,
     "must be <= 8192"),
    ("render:\n  spp: 10000000\n", "render.spp", 2, "must be <= 1048576"),
    ("fit:\n  view_gmm:\n    samples: 1048576\n    theta_count: 256\n",
     "fit.view_gmm.samples", 3, "at most 2^25"),
    ("transport:\n  chunk_vertices: 100000\n", "transport.chunk_vertices", 2,
     "must be <= 4096"),
    ("visibility:\n  trace_resolution: 100000\n", "visibility.trace_resolution", 2,
     "must be <= 2048"),
    ("visibility:\n  trace_resolution: 32\n  resolution: 16\n  pca_terms: 300\n",
     "visibility.pca_terms", 4, "at most resolution² (256"),
    ("render:\n  camera:\n    fov_deg: abc\n", "render.camera.fov_deg", 3, "expected a number"),
    ("render:\n  camera:\n    eye: [1, 2]\n", "render.camera.eye", 3, "expected 3 values"),
    ("render:\n  camera: 7\n", "render.camera", 2, "expected a mapping"),
    ("scene:\n  objects:\n    - name: a\n", "scene.objects.0.mesh", 3, "exactly one"),
])
def test_bad_values_name_file_key_and_line(tmp_path, text, key, line, msg):
    p = write(tmp_path, text)
    with pytest.raises(BadInput) as e:
        load_config(p)
    one = e.value.one_line()
    assert e.value.key == key and e.value.line == line and msg in one
    assert one.startswith(f"{p}:{line}: {key}: ")


def test_cross_field_rule_names_the_key(tmp_path):
    """A rule checked after the types (EnvmapSection.validate): 0 < k < 1 texels per σ."""
    (tmp_path / "env.exr").write_bytes(b"")
    p = write(tmp_path, "envmap:\n  environment: env.exr\n  pyramid_texels_per_sigma: 0.5\n")
    with pytest.raises(BadInput) as e:
        load_config(p)
    assert e.value.key == "envmap.pyramid_texels_per_sigma"
    assert "0 (automatic) or >= 1, got 0.5" in e.value.one_line()
    for ok in ("0", "1.5"):
        q = write(tmp_path, f"envmap:\n  environment: env.exr\n  pyramid_texels_per_sigma: {ok}\n")
        assert load_config(q).envmap.pyramid_texels_per_sigma == float(ok)


def test_malformed_yaml_and_missing_file(tmp_path):
    with pytest.raises(BadInput, match="malformed YAML") as e:
        load_config(write(tmp_path, "name: [unclosed\n"))
    assert e.value.line is not None
    with pytest.raises(BadInput, match="config file not found"):
        load_config(tmp_path / "nope.yaml")
    with pytest.raises(BadInput, match="top level must be a mapping"):
        load_config(write(tmp_path, "- 1\n- 2\n"))


def test_unsafe_yaml_tags_are_rejected(tmp_path):
    p = write(tmp_path, "name: !!python/object/apply:os.system ['echo hi']\n")
    with pytest.raises(BadInput, match="malformed YAML"):
        load_config(p)


def test_paths_are_relative_to_the_config_file(tmp_path):
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "m.obj").write_text("v 0 0 0\n")
    p = write(sub, "scene:\n  objects:\n    - {name: a, mesh: m.obj}\n")
    cfg = load_config(p)
    assert Path(cfg.scene.objects[0].mesh) == (sub / "m.obj").resolve()
    p2 = write(sub, "scene:\n  objects:\n    - {name: a, mesh: missing.obj}\n", "c2.yaml")
    with pytest.raises(BadInput, match="file not found") as e:
        load_config(p2)
    assert e.value.key == "scene.objects.0.mesh"


def test_set_overrides(tmp_path):
    p = write(tmp_path, "render:\n  camera:\n    width: 32\n")
    cfg = load_config(p, ["render.camera.width=64", "render.camera.eye=[0, 0, 9]", "seed=3"])
    assert cfg.render.camera.width == 64 and cfg.render.camera.eye == (0.0, 0.0, 9.0)
    assert cfg.seed == 3
    with pytest.raises(BadInput) as e:
        load_config(p, ["render.camera.width=wide"])
    assert e.value.key == "render.camera.width"
    with pytest.raises(BadInput, match="key.path=value"):
        load_config(p, ["nonsense"])


def test_resolved_config_round_trips_through_yaml(tmp_path):
    cfg = load_config(write(tmp_path, "name: x\nrender: {}\n"))
    plain = to_plain(cfg)
    plain.pop("source")
    text = yaml.safe_dump(plain, sort_keys=True)
    again = load_config(write(tmp_path, text, "again.yaml"))
    plain2 = to_plain(again)
    plain2.pop("source")
    assert plain2 == plain


def _alias_bomb(levels=9, width=9) -> str:
    rows = ['l0: &l0 [' + ", ".join(['"x"'] * width) + ']']
    for i in range(1, levels):
        rows.append(f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * width) + "]")
    return "\n".join(rows) + "\n"


def test_alias_bomb_is_one_line_in_bounded_memory_and_time(tmp_path):
    """A 500-byte YAML whose aliases expand to 9⁹ nodes (it grew to 3.1 GB and a MemoryError
    traceback when the line map expanded it): through the real CLI under a 1 GiB address-space
    limit, exit 2 within seconds, one line naming the file and line, nothing written."""
    import resource
    import subprocess
    import sys
    import time
    p = write(tmp_path, _alias_bomb())
    assert p.stat().st_size < 600

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))

    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(p), "--out",
                        str(tmp_path / "out")], capture_output=True, text=True,
                       preexec_fn=limit, timeout=60)
    assert r.returncode == 2, r.stderr
    assert time.monotonic() - t0 < 20
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"sgpipe: error: {p}:"), r.stderr
    assert "aliases" in lines[0]
    assert not (tmp_path / "out").exists()


def test_duplicate_keys_are_refused_with_both_lines(tmp_path):
    p = write(tmp_path, "name: a\nrender:\n  spp: 4\n  spp: 8\n")
    with pytest.raises(BadInput, match=r"duplicate key 'spp' \(first on line 3\)") as e:
        load_config(p)
    assert e.value.line == 4
    with pytest.raises(BadInput, match="duplicate key 'name'"):
        load_config(write(tmp_path, "name: a\nseed: 1\nname: b\n"))


def test_anchors_aliases_and_merge_keys_still_load(tmp_path):
    """What YAML users write on purpose (a shared camera, a merged base material) is kept."""
    p = write(tmp_path, """
        name: x
        seed: &s 3
        fit:
          materials:
            - &base {name: a, model: ggx, params: {alpha: 0.2, ks: 0.5}}
            - {<<: *base, name: b}
        render:
          camera: &cam {width: 16, height: 16}
          spp: *s
        """)
    cfg = load_config(p)
    assert cfg.render.spp == 3 and cfg.render.camera.width == 16
    assert [m.name for m in cfg.fit.materials] == ["a", "b"]
    assert cfg.fit.materials[1].params == cfg.fit.materials[0].params


def test_recursive_alias_is_one_line(tmp_path):
    """`x: &x [*x]` (found by tests/foundation/test_fuzz.py) sent the line map into unbounded
    recursion (RecursionError traceback)."""
    with pytest.raises(BadInput, match="recursive alias"):
        load_config(write(tmp_path, "name: a\nx: &x [1, *x]\n"))
