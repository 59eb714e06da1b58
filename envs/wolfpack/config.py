"""Scenario parameters: YAML in, validated dict out.

The schema lives in Rust (``rust/core/src/config/``): unknown keys, wrong types and out-of-range
values are rejected there, and the error names the key. This module only reads YAML and applies
dotted overrides such as ``{"world.wolves": 8}`` (CLI: ``--set world.wolves=8``).

Numbers are read as YAML 1.2 and JSON read them: ``1e-3`` and ``1E5`` are floats (PyYAML's
YAML 1.1 resolver would leave them strings). Input is bounded before anything else looks at
it: a params or layout file of at most :data:`MAX_FILE_BYTES`, nested at most
:data:`MAX_DEPTH` levels, with at most :data:`MAX_NODES` values counting every use of a YAML
alias (so that an alias bomb is refused rather than expanded) — :func:`check_tree`.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from wolfpack import _core

#: The documented scenario, shipped inside the package (the repository's ``params.yaml``).
DEFAULT_PARAMS_PATH = Path(__file__).with_name("params.yaml")

#: The largest params or layout file read (1 MiB; the documented scenario is 3 KiB).
MAX_FILE_BYTES = 1 << 20
#: The deepest nesting of mappings and lists accepted in params, overrides and layouts.
MAX_DEPTH = 32
#: The most values (mappings, lists and scalars, every use of a YAML alias counted again) in
#: one params tree, override value or layout.
MAX_NODES = 1_000_000


class _Loader(yaml.SafeLoader):
    """SafeLoader that reads numbers as YAML 1.2 (and JSON) do: ``1e-3``, ``1E5`` and ``1.5e3``
    are floats; YAML 1.1's resolver, PyYAML's, wants a dot and a signed exponent."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
        |[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def _yaml(text: str) -> Any:
    return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass


def _children(node: Any) -> Any:
    """The values a mapping or a list holds, or None for a scalar (a numeric array too)."""
    if isinstance(node, Mapping):
        return list(node.values())
    if isinstance(node, (list, tuple)):
        return node
    if isinstance(node, np.ndarray) and node.dtype == object:
        return node.ravel().tolist()
    return None


def check_tree(obj: Any, what: str, *, max_depth: int = MAX_DEPTH, max_nodes: int = MAX_NODES, level: int = 1) -> None:
    """ValueError naming ``what`` if ``obj`` nests mappings/lists deeper than ``max_depth``
    levels or holds more than ``max_nodes`` values once expanded (each mapping, list and
    scalar counts one; a numeric array its size). ``level``: the level ``obj`` itself sits at
    (an override's value sits below the sections its dotted key names).

    Iterative (no recursion limit to hit) and linear in the number of *distinct* containers:
    an object used many times (a YAML alias, a list appended to itself twice) has its expanded
    size counted every time it is used, but is walked once and never expanded, so an alias
    bomb ("billion laughs") is refused at once; a structure that contains itself is infinitely
    deep."""
    too_deep = f"{what}: nested deeper than {max_depth} levels"
    too_big = f"{what}: more than {max_nodes} values (every use of a YAML alias counts)"
    if _children(obj) is None:
        if isinstance(obj, np.ndarray) and obj.size > max_nodes:
            raise ValueError(too_big)
        return
    size: dict[int, int] = {}  # id(container) -> expanded count, itself included
    height: dict[int, int] = {}  # id(container) -> levels of nesting from it down (1: no child container)
    on_path: set[int] = set()
    stack: list[tuple[Any, int, bool]] = [(obj, level, False)]  # (container, its depth from obj, children done)
    while stack:
        node, depth, done = stack.pop()
        key = id(node)
        children = _children(node)
        if done:
            on_path.discard(key)
            total, levels = 1, 1
            for child in children:
                ck = id(child)
                if ck in size:
                    total += size[ck]
                    levels = max(levels, height[ck] + 1)
                else:  # a scalar
                    total += child.size if isinstance(child, np.ndarray) else 1
            if total > max_nodes:
                raise ValueError(too_big)
            if depth - 1 + levels > max_depth:
                raise ValueError(too_deep)
            size[key], height[key] = total, levels
            continue
        if key in size:  # seen before, reached again through another path
            if depth - 1 + height[key] > max_depth:
                raise ValueError(too_deep)
            continue
        if key in on_path or depth > max_depth:  # it contains itself, or plainly too deep
            raise ValueError(too_deep)
        on_path.add(key)
        stack.append((node, depth, True))
        for child in children:
            if _children(child) is not None and id(child) not in size:
                stack.append((child, depth + 1, False))


def _read_text(path: Path, what: str) -> str:
    """The file's text, refused (ValueError naming it) when unreadable, larger than
    :data:`MAX_FILE_BYTES` or not UTF-8. Reads at most one byte past the limit (a FIFO or
    /dev/zero cannot make it read forever)."""
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise ValueError(f"{what} {path}: cannot read ({e.strerror or e})") from None
    if len(data) > MAX_FILE_BYTES:
        raise ValueError(f"{what} {path}: larger than {MAX_FILE_BYTES // (1 << 20)} MiB, the limit for a {what} file")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ValueError(f"{what} {path}: not UTF-8 text (byte {e.start})") from None


def _read_yaml(path: Path, what: str) -> Any:
    text = _read_text(path, what)
    try:
        data = _yaml(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        raise ValueError(f"{what} {path}:{where} is not valid YAML ({' '.join(str(getattr(e, 'problem', None) or e).split())})") from None
    except RecursionError:
        raise ValueError(f"{what} {path}: nested deeper than {MAX_DEPTH} levels") from None
    except ValueError as e:  # e.g. an integer of more digits than Python converts
        raise ValueError(f"{what} {path}: {' '.join(str(e).split())}") from None
    check_tree(data, f"{what} {path}")
    return data


def _short(key: str, limit: int = 80) -> str:
    """A key for a one-line message (a pathological one is cut)."""
    return key if len(key) <= limit else f"{key[:limit]}..."


def parse_override(text: str, option: str = "--set") -> tuple[str, Any]:
    """``"world.wolves=8"`` → ``("world.wolves", 8)``; the value is read as YAML (numbers,
    booleans, lists like ``[-5,-5,5,5]``, ``null``, strings; ``1e-3`` is a float). Errors name
    ``option``, the command-line option the text came from."""
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValueError(f"{option} {_short(text)!r}: expected key=value, e.g. {'learning_rate=1e-4' if option == '--hp' else 'world.wolves=8'}")
    try:
        parsed = _yaml(value) if value.strip() else None
    except yaml.YAMLError:
        raise ValueError(f"{option} {_short(key)}: cannot read value {_short(value)!r}") from None
    except RecursionError:
        raise ValueError(f"{option} {_short(key)}: value nested deeper than {MAX_DEPTH} levels") from None
    except ValueError as e:
        raise ValueError(f"{option} {_short(key)}: {' '.join(str(e).split())}") from None
    check_tree(parsed, f"{option} {_short(key)}")
    return key, parsed


def check_overrides(overrides: Any) -> Mapping[str, Any]:
    """``overrides`` must be a mapping of dotted keys (TypeError otherwise); each value is
    bounded like a params tree (:func:`check_tree`, ValueError naming the key)."""
    if not isinstance(overrides, Mapping):
        raise TypeError(f"overrides must be a mapping of dotted keys to values, e.g. {{'world.wolves': 8}}, got {type(overrides).__name__}")
    for dotted, value in overrides.items():
        parts = str(dotted).split(".")
        if len(parts) > MAX_DEPTH:
            raise ValueError(f"override {_short(str(dotted))}: nested deeper than {MAX_DEPTH} levels")
        check_tree(value, f"override {_short(str(dotted))}", level=len(parts) + 1)
    return overrides


def apply_overrides(params: dict, overrides: Mapping[str, Any]) -> dict:
    """Sets dotted keys in a nested dict (a copy). Unknown keys are left for the Rust validator
    to reject by name; a key that would descend into a non-section is rejected here. Both are
    bounded first (:func:`check_tree`, :func:`check_overrides`)."""
    check_tree(params, "params")
    check_overrides(overrides)
    out = json.loads(json.dumps(params))  # deep copy of plain data
    for dotted, value in overrides.items():
        parts = str(dotted).split(".")
        node = out
        for i, part in enumerate(parts[:-1]):
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                raise ValueError(f"{_short('.'.join(parts[: i + 1]))}: is a value, not a section (in override {_short(str(dotted))})")
            node = child
        node[parts[-1]] = value
    return out


def load_params(path: str | Path | None = None, overrides: Mapping[str, Any] | None = None) -> dict:
    """Reads a scenario and validates it.

    Args:
        path: a YAML file; ``None`` reads the documented scenario (:data:`DEFAULT_PARAMS_PATH`).
            Missing keys take their documented defaults.
        overrides: dotted keys to set, e.g. ``{"world.wolves": 8, "policies.targets": "still"}``.

    Returns:
        The complete, validated parameter dict (``capture.count`` stays ``None`` when left
        to derive; the envs' ``params`` and ``_core.validate_params(p, resolve=True)`` fill it in).

    Raises:
        ValueError: unreadable file, invalid YAML, a file over :data:`MAX_FILE_BYTES`, nesting
            deeper than :data:`MAX_DEPTH` or more than :data:`MAX_NODES` values (in the file or
            an override), unknown key, wrong type, value out of range — the message names the
            file, the override or the key.
        TypeError: ``overrides`` is not a mapping.
    """
    if overrides is not None:
        check_overrides(overrides)
    raw = _read_yaml(Path(path) if path is not None else DEFAULT_PARAMS_PATH, "params")
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise ValueError(f"params {path}: the top level must be a mapping of sections, got {type(raw).__name__}")
    if overrides:
        raw = apply_overrides(raw, overrides)
    return _core.validate_params(raw)


def load_layout(path: str | Path) -> dict:
    """Reads an explicit layout (a JSON file) — the layout format of docs/interface.md. Shape checks
    happen when it is used (:func:`wolfpack.run_episodes` / ``_core.check_layout``)."""
    text = _read_text(Path(path), "layout")
    try:
        layout = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"layout {path}: not valid JSON (line {e.lineno}: {e.msg})") from None
    except RecursionError:
        raise ValueError(f"layout {path}: nested deeper than {MAX_DEPTH} levels") from None
    except ValueError as e:  # e.g. an integer of more digits than Python converts
        raise ValueError(f"layout {path}: {' '.join(str(e).split())}") from None
    check_tree(layout, f"layout {path}")
    if not isinstance(layout, dict):
        raise ValueError(f"layout {path}: must be a JSON object with wolves, targets, obstacles")
    return layout
