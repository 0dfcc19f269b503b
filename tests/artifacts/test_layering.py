"""sgpipe.artifacts sits below the algorithm packages: it imports only io, errors and core."""
import ast
from pathlib import Path

import sgpipe.artifacts

ALLOWED = ("sgpipe.io", "sgpipe.errors", "sgpipe.core", "sgpipe.artifacts")


def test_artifacts_import_only_io_errors_core():
    root = Path(sgpipe.artifacts.__file__).parent
    bad = []
    for f in sorted(root.glob("*.py")):
        for node in ast.walk(ast.parse(f.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            bad += [f"{f.name}: {n}" for n in names
                    if n.startswith("sgpipe") and not n.startswith(ALLOWED)]
    assert len(list(root.glob("*.py"))) >= 4
    assert not bad, bad
