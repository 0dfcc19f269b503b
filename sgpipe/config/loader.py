"""Load a YAML config (safe_load only), apply `--set key.path=value` overrides, validate."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from sgpipe.config.schema import Context, build
from sgpipe.errors import BadInput


def _line_map(node, path=(), out=None) -> dict[tuple, int]:
    """Dotted key path -> 1-based line, from the composed YAML node tree."""
    out = {} if out is None else out
    if isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            key = path + (k.value,)
            out[key] = k.start_mark.line + 1
            _line_map(v, key, out)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            out[path + (i,)] = v.start_mark.line + 1
            _line_map(v, path + (i,), out)
    return out


#: Nodes a config may expand to with its aliases resolved: a real config has hundreds, and an
#: alias bomb (nine levels of nine aliases: 500 bytes) would expand to 10⁹.
MAX_EXPANDED_NODES = 100_000


def _check_tree(node, path: Path) -> None:
    """Refuse a duplicate key in any mapping (YAML leaves it to the loader; PyYAML keeps the
    last one silently), a recursive alias, and a document whose aliases expand it past
    MAX_EXPANDED_NODES. Sizes are memoised per node, so an alias bomb is measured without
    being expanded."""
    sizes: dict[int, int] = {}
    open_: set[int] = set()       # nodes whose size is being measured: the path from the root

    def size(n) -> int:
        if id(n) in open_:
            raise BadInput("an alias refers to a node that contains it (a recursive alias); "
                           "a config is a tree", file=path, line=n.start_mark.line + 1)
        got = sizes.get(id(n))
        if got is not None:
            return got
        open_.add(id(n))
        total = 1
        if isinstance(n, yaml.MappingNode):
            seen: dict[tuple, int] = {}
            for k, v in n.value:
                if isinstance(k, yaml.ScalarNode):
                    ident = (k.tag, k.value)         # 1 and '1' are different keys
                    if ident in seen:
                        raise BadInput(f"duplicate key {k.value!r} (first on line "
                                       f"{seen[ident]})", file=path, line=k.start_mark.line + 1)
                    seen[ident] = k.start_mark.line + 1
                total += size(k) + size(v)
                if total > MAX_EXPANDED_NODES:
                    break
        elif isinstance(n, yaml.SequenceNode):
            for v in n.value:
                total += size(v)
                if total > MAX_EXPANDED_NODES:
                    break
        if total > MAX_EXPANDED_NODES:
            raise BadInput(f"the document expands to more than {MAX_EXPANDED_NODES} nodes "
                           "through its aliases (&anchor / *alias); a config needs far fewer",
                           file=path, line=n.start_mark.line + 1)
        open_.discard(id(n))
        sizes[id(n)] = total
        return total

    size(node)


def parse_yaml(path: Path) -> tuple[Any, dict[tuple, int]]:
    """Read and parse a YAML file; any failure is one BadInput line naming the file."""
    if not path.is_file():
        raise BadInput("config file not found", file=path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise BadInput(f"cannot read config ({e})", file=path) from None
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        if node is None:
            return None, {}
        _check_tree(node, path)
        data = yaml.SafeLoader("").construct_document(node)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise BadInput(f"malformed YAML: {problem}", file=path,
                       line=(mark.line + 1) if mark else None) from None
    return data, _line_map(node)


def apply_override(data: dict, assignment: str, file: Path | None) -> None:
    """Apply one `key.path=value` (value parsed as YAML) to the raw config mapping."""
    key, sep, value = assignment.partition("=")
    if not sep or not key:
        raise BadInput(f"--set expects key.path=value, got {assignment!r}", file=file, key="--set")
    try:
        parsed = yaml.safe_load(value) if value != "" else ""
    except yaml.YAMLError:
        parsed = value
    parts = key.split(".")
    node: Any = data
    for i, part in enumerate(parts[:-1]):
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise BadInput("no such list index", file=file, key=".".join(parts[:i + 1]))
            node = node[int(part)]
        else:
            if node.get(part) is None:
                node[part] = {}
            node = node[part]
        if not isinstance(node, (dict, list)):
            raise BadInput("cannot set inside a scalar", file=file, key=".".join(parts[:i + 1]))
    last = parts[-1]
    if isinstance(node, list):
        if not last.isdigit() or int(last) >= len(node):
            raise BadInput("no such list index", file=file, key=key)
        node[int(last)] = parsed
    else:
        node[last] = parsed


def load_config(path: str | Path, overrides: tuple[str, ...] | list[str] = ()):
    """Return the validated root `Config` of a YAML file, after `--set` overrides."""
    from sgpipe.config.root import Config

    path = Path(path).resolve()
    data, lines = parse_yaml(path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise BadInput("top level must be a mapping", file=path, line=1)
    for ov in overrides:
        apply_override(data, ov, path)
    cfg = build(Config, data, (), Context(file=path, lines=lines))
    cfg.source = path
    from sgpipe.config.gltf_scene import expand_gltf
    expand_gltf(cfg)
    return cfg
