"""The rendering side's packages import one way: scene (camera, tracer) below render and
reference, which do not import each other; metrics stands alone; the config reaches render
only through the dependency-free method registry."""

import ast
from pathlib import Path

import pytest

import sgpipe

ROOT = Path(sgpipe.__file__).parent
BASE = ("sgpipe.core", "sgpipe.errors", "sgpipe.io")
ALLOWED = {
    "scene": BASE + ("sgpipe.scene",),
    "metrics": BASE + ("sgpipe.metrics",),
    "reference": BASE + ("sgpipe.brdf", "sgpipe.parallel", "sgpipe.scene", "sgpipe.reference"),
    "render": BASE + ("sgpipe.artifacts", "sgpipe.brdf", "sgpipe.scene", "sgpipe.render"),
}


def _imports(path: Path) -> list[str]:
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            out.append(node.module or "")
    return [n for n in out if n.startswith("sgpipe")]


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_package_imports_only_lower_layers(package):
    files = sorted((ROOT / package).rglob("*.py"))
    assert files
    bad = [f"{f.relative_to(ROOT)}: {n}" for f in files for n in _imports(f)
           if not n.startswith(ALLOWED[package])]
    assert not bad, bad


def test_method_registry_is_plain_data():
    """The config derives `render.methods` from sgpipe.render.methods: it imports nothing."""
    assert _imports(ROOT / "render" / "methods.py") == []
    names = {n for f in (ROOT / "config").rglob("*.py") for n in _imports(f)}
    assert {n for n in names if n.startswith("sgpipe.render")} == {"sgpipe.render.methods"}
