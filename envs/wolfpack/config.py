"""Scenario parameters: YAML in, validated dict out.

The schema lives in Rust (``rust/core/src/config.rs``): unknown keys, wrong types and out-of-range
values are rejected there, and the error names the key. This module only reads YAML and applies
dotted overrides such as ``{"world.wolves": 8}`` (CLI: ``--set world.wolves=8``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping

import yaml

from wolfpack import _core

#: The documented scenario, shipped inside the package (the repository's ``params.yaml``).
DEFAULT_PARAMS_PATH = Path(__file__).with_name("params.yaml")


def _read_yaml(path: Path, what: str) -> Any:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as e:
        raise ValueError(f"{what} {path}: cannot read ({e.strerror or e})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        raise ValueError(f"{what} {path}:{where} is not valid YAML ({getattr(e, 'problem', e)})") from None


def parse_override(text: str) -> tuple[str, Any]:
    """``"world.wolves=8"`` → ``("world.wolves", 8)``; the value is read as YAML (numbers,
    booleans, lists like ``[-5,-5,5,5]``, ``null``, strings)."""
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValueError(f"--set {text!r}: expected key=value, e.g. world.wolves=8")
    try:
        return key, yaml.safe_load(value) if value.strip() else None
    except yaml.YAMLError:
        raise ValueError(f"{key}: cannot read value {value!r}") from None


def apply_overrides(params: dict, overrides: Mapping[str, Any]) -> dict:
    """Sets dotted keys in a nested dict (a copy). Unknown keys are left for the Rust validator
    to reject by name; a key that would descend into a non-section is rejected here."""
    out = json.loads(json.dumps(params))  # deep copy of plain data
    for dotted, value in overrides.items():
        parts = str(dotted).split(".")
        node = out
        for i, part in enumerate(parts[:-1]):
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                raise ValueError(f"{'.'.join(parts[: i + 1])}: is a value, not a section (in override {dotted})")
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
        ValueError: unreadable file, invalid YAML, unknown key, wrong type, value out of range —
            the message names the key.
    """
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
    text_path = Path(path)
    try:
        text = text_path.read_text(encoding="utf-8")
    except OSError as e:
        raise ValueError(f"layout {path}: cannot read ({e.strerror or e})") from None
    try:
        layout = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"layout {path}: not valid JSON (line {e.lineno}: {e.msg})") from None
    if not isinstance(layout, dict):
        raise ValueError(f"layout {path}: must be a JSON object with wolves, targets, obstacles")
    return layout
