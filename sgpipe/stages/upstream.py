"""Whether an upstream stage's folder was made for the current config: a stage that reads
another's artifacts (render reads fit, envmap, visibility, transport, normalmap) refuses ones
made for another config instead of using them silently."""

from __future__ import annotations

from pathlib import Path

import yaml

from sgpipe.stages.base import resolved_config


def upstream_difference(cfg, out_dir: Path, stage: str, sections: tuple[str, ...]) -> str | None:
    """Where this config differs from the one OUT/<stage> was made with, in the `sections`
    (dotted paths; `*` takes every element of a list) that stage computes from:
    'KEY: OLD -> NEW' for the first difference, None when they agree (or the folder records no
    config)."""
    path = Path(out_dir) / stage / "config.resolved.yaml"
    try:
        old = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError):
        return None
    new = yaml.safe_load(yaml.safe_dump(resolved_config(cfg), sort_keys=True))
    if not isinstance(old, dict):
        return None

    def at(d, dotted):
        parts = dotted.split(".")
        for k, part in enumerate(parts):
            if part == "*":               # every element of a list
                rest = ".".join(parts[k + 1:])
                return [at(x, rest) if rest else x for x in d] if isinstance(d, list) else None
            d = d.get(part) if isinstance(d, dict) else None
        return d

    def first(a, b, key):
        if isinstance(a, dict) and isinstance(b, dict):
            for k in sorted(set(a) | set(b), key=str):
                got = first(a.get(k), b.get(k), f"{key}.{k}")
                if got:
                    return got
            return None
        if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
            for i, (x, y) in enumerate(zip(a, b)):
                got = first(x, y, f"{key}.{i}")
                if got:
                    return got
            return None
        return None if a == b else f"{key}: {a!r} -> {b!r}"

    for sec in sections:
        got = first(at(old, sec), at(new, sec), sec)
        if got and "*" in sec:        # 'a.*.b.3: …' reads 'a.3.b: …'
            head, _, rest = got.partition(": ")
            idx, _, tail = head[len(sec) + 1:].partition(".")
            if idx.isdigit():
                got = sec.replace("*", idx) + (f".{tail}" if tail else "") + ": " + rest
        if got:
            return got
    return None


__all__ = ["upstream_difference"]
