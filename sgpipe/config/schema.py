"""Typed config machinery: dataclass sections -> validated objects with key paths in errors.

A section is a dataclass whose fields carry `metadata={"doc": ..., "ge"/"gt"/"le"/"lt": ...}`
(use the `doc()` helper). Supported field types: bool, int, float, str, InputPath, OutputName,
Literal[...], `T | None`, list[T], tuple[T, ...] / tuple[T1, T2], dict[str, T] and nested
dataclasses. Unknown keys, wrong types and out-of-range numbers raise BadInput naming the
config file, the line and the dotted key path.
"""

from __future__ import annotations

import dataclasses
import os
import types
import typing
from dataclasses import MISSING, dataclass, field, fields, is_dataclass
from pathlib import Path
from typing import Any, Literal, get_args, get_origin

from sgpipe.errors import BadInput


class InputPath(str):
    """A file path in a config: relative to the config file; must exist. The string is the
    absolute path (what code opens); `relative` is the path from the config file's folder,
    what the resolved config and parameter hashes record, so that artifacts do not depend on
    where the checkout sits (the manifest hashes the file's content)."""

    relative: str

    @classmethod
    def resolved(cls, path: Path, base: Path) -> "InputPath":
        ip = cls(str(path))
        ip.relative = Path(os.path.relpath(path, base.resolve())).as_posix()
        return ip


class OutputName(str):
    """A file name inside the stage's output folder (no directories, no '..')."""


def doc(text: str, default: Any = MISSING, *, default_factory: Any = MISSING, **bounds) -> Any:
    """A documented dataclass field. `bounds` may hold ge, gt, le, lt (numeric limits)."""
    meta = {"doc": text, **bounds}
    if default_factory is not MISSING:
        return field(default_factory=default_factory, metadata=meta)
    return field(default=default, metadata=meta)


@dataclass
class Context:
    """Where values came from: the config file (for relative paths and messages) and lines."""
    file: Path | None
    lines: dict[tuple, int]

    def line(self, path: tuple) -> int | None:
        while path:
            if path in self.lines:
                return self.lines[path]
            path = path[:-1]
        return None

    def error(self, path: tuple, message: str) -> BadInput:
        key = ".".join(str(p) for p in path) or "<root>"
        return BadInput(message, file=self.file, key=key, line=self.line(path))


def _type_name(tp: Any) -> str:
    if tp is InputPath:
        return "path"
    if tp is OutputName:
        return "file name"
    origin = get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        inner = [_type_name(a) for a in get_args(tp) if a is not type(None)]
        none = type(None) in get_args(tp)
        return " or ".join(inner) + (" or null" if none else "")
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(tp))
    if origin is list:
        return f"list of {_type_name(get_args(tp)[0])}"
    if origin is tuple:
        args = get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"list of {_type_name(args[0])}"
        return "[" + ", ".join(_type_name(a) for a in args) + "]"
    if origin is dict:
        return "mapping"
    if is_dataclass(tp):
        return "mapping"
    if tp is Any:
        return "any"
    return getattr(tp, "__name__", str(tp))


def _check_bounds(value, meta, path, ctx):
    for op, test, word in (("ge", lambda a, b: a >= b, ">="), ("gt", lambda a, b: a > b, ">"),
                           ("le", lambda a, b: a <= b, "<="), ("lt", lambda a, b: a < b, "<")):
        if op in meta and not test(value, meta[op]):
            raise ctx.error(path, f"must be {word} {meta[op]}, got {value}")


def convert(tp: Any, value: Any, path: tuple, ctx: Context, meta: dict | None = None) -> Any:
    """Validate and convert a raw YAML value to type `tp`."""
    meta = meta or {}
    origin = get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = get_args(tp)
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return convert(inner[0], value, path, ctx, meta)
        errors = []
        for a in inner:
            try:
                return convert(a, value, path, ctx, meta)
            except BadInput as e:
                errors.append(e)
        raise ctx.error(path, f"expected {' or '.join(_type_name(a) for a in inner)}, "
                              f"got {value!r}")
    if is_dataclass(tp):
        return build(tp, value, path, ctx)
    if origin is Literal:
        choices = get_args(tp)
        if value not in choices or isinstance(value, bool) != isinstance(choices[0], bool):
            raise ctx.error(path, f"must be {_type_name(tp)}, got {value!r}")
        return value
    if origin is list:
        (item,) = get_args(tp)
        if not isinstance(value, list):
            raise ctx.error(path, f"expected a list, got {value!r}")
        out = [convert(item, v, path + (i,), ctx) for i, v in enumerate(value)]
        if "min_len" in meta and len(out) < meta["min_len"]:
            raise ctx.error(path, f"needs at least {meta['min_len']} entries")
        return out
    if origin is tuple:
        args = get_args(tp)
        if not isinstance(value, list):
            raise ctx.error(path, f"expected a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(convert(args[0], v, path + (i,), ctx) for i, v in enumerate(value))
        if len(value) != len(args):
            raise ctx.error(path, f"expected {len(args)} values, got {len(value)}")
        return tuple(convert(a, v, path + (i,), ctx) for i, (a, v) in enumerate(zip(args, value)))
    if origin is dict:
        _, vt = get_args(tp)
        if not isinstance(value, dict):
            raise ctx.error(path, f"expected a mapping, got {value!r}")
        return {str(k): convert(vt, v, path + (k,), ctx) for k, v in value.items()}
    if tp is bool:
        if not isinstance(value, bool):
            raise ctx.error(path, f"expected true/false, got {value!r}")
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ctx.error(path, f"expected an integer, got {value!r}")
        _check_bounds(value, meta, path, ctx)
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ctx.error(path, f"expected a number, got {value!r}")
        value = float(value)
        if value != value or value in (float("inf"), float("-inf")):
            raise ctx.error(path, f"must be finite, got {value!r}")
        _check_bounds(value, meta, path, ctx)
        return value
    if tp is InputPath:
        if not isinstance(value, str) or not value:
            raise ctx.error(path, f"expected a file path, got {value!r}")
        p = Path(value).expanduser()
        base = ctx.file.parent if ctx.file else Path.cwd()
        if not p.is_absolute():
            p = base / p
        p = p.resolve()
        if not p.exists():
            raise ctx.error(path, f"file not found: {p}")
        return InputPath.resolved(p, base)
    if tp is OutputName:
        if not isinstance(value, str) or not value or "/" in value or value.startswith("."):
            raise ctx.error(path, f"expected a plain file name, got {value!r}")
        return OutputName(value)
    if tp is str:
        if not isinstance(value, str):
            raise ctx.error(path, f"expected a string, got {value!r}")
        return value
    if tp is Any:
        return value
    raise TypeError(f"unsupported config type {tp!r} at {path}")


def build(cls: type, raw: Any, path: tuple, ctx: Context) -> Any:
    """Build dataclass `cls` from a mapping, rejecting unknown keys and missing required ones."""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise ctx.error(path, f"expected a mapping, got {raw!r}")
    hints = typing.get_type_hints(cls)
    known = {f.name: f for f in fields(cls)}
    for k in raw:
        if k not in known:
            close = ", ".join(sorted(known))
            raise ctx.error(path + (k,), f"unknown key (known: {close})")
    kwargs = {}
    for name, f in known.items():
        if name in raw:
            kwargs[name] = convert(hints[name], raw[name], path + (name,), ctx, dict(f.metadata))
        elif f.default is MISSING and f.default_factory is MISSING:
            raise ctx.error(path + (name,), "required key is missing")
    obj = cls(**kwargs)
    check = getattr(obj, "validate", None)
    if check is not None:
        try:
            check()
        except ValueError as e:  # cross-field rules raise ValueError("key: message")
            key, _, msg = str(e).partition(": ")
            raise ctx.error(path + tuple(key.split(".")), msg or str(e)) from None
    return obj


def to_plain(obj: Any) -> Any:
    """Dataclass tree -> plain YAML/JSON-able data (for the resolved config and hashing)."""
    if is_dataclass(obj):
        return {f.name: to_plain(getattr(obj, f.name)) for f in fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [to_plain(v) for v in obj]
    if isinstance(obj, dict):
        return {str(k): to_plain(v) for k, v in obj.items()}
    if isinstance(obj, InputPath):
        return getattr(obj, "relative", str(obj))
    if isinstance(obj, str):
        return str(obj)
    return obj


def describe(cls: type, indent: int = 0) -> list[str]:
    """Documentation lines for a section: key, type, default, doc (used by `sgpipe config-doc`)."""
    hints = typing.get_type_hints(cls)
    lines = []
    for f in fields(cls):
        tp = hints[f.name]
        if f.default is not MISSING:
            default = repr(to_plain(f.default))
        elif f.default_factory is not MISSING:
            default = repr(to_plain(f.default_factory()))
        else:
            default = "required"
        lines.append(f"{'  ' * indent}{f.name}: {_type_name(tp)} = {default}  "
                     f"# {f.metadata.get('doc', '')}")
        sub = [a for a in (get_args(tp) or (tp,)) if is_dataclass(a)]
        if not sub and get_origin(tp) is list and is_dataclass(get_args(tp)[0]):
            sub = [get_args(tp)[0]]
        for s in sub:
            lines += describe(s, indent + 1)
    return lines


__all__ = ["InputPath", "OutputName", "doc", "Context", "build", "convert", "to_plain",
           "describe", "dataclass", "dataclasses"]
