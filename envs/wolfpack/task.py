"""The benchmark's named, versioned tasks (docs/tasks.md).

A task is a frozen params file in the package (``tasks/<name>.yaml``: its name, a one-line
description and the *complete* params), so that it stays what it was when the defaults of the
documented scenario change. A task's version (``-v1``) changes whenever anything that alters its
outcomes changes; ``tests/test_tasks.py`` pins every task's scripted outcomes so that a silent
change fails.

Every interface takes ``task=NAME``: :class:`wolfpack.BatchEnv`, :func:`wolfpack.make_vec_env`,
:func:`wolfpack.parallel_env`, :func:`wolfpack.env`, ``wolfpack hunt --task NAME``, and
Gymnasium ids ``wolfpack/Escape-<task>`` for the tasks with one target (one learning target
against the scripted wolves). Overrides apply on top of the task's params.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from wolfpack import _core
from wolfpack.config import _read_yaml, apply_overrides

#: The folder of the task files.
TASKS_DIR = Path(__file__).with_name("tasks")
#: The tasks in the order tables list them: the documented scenario first.
TASK_ORDER = ("hunt-v1", "open-v1", "cluttered-v1", "fast-target-v1", "small-pack-v1", "two-targets-v1", "short-sight-v1")
#: Params sections that are not the task itself: who plays it (``policies``: the laws being
#: compared on it), what a learner observes (``env``) and what it is paid (``rewards``); the
#: last two never change how a scripted episode moves or ends. A task run with overrides
#: elsewhere is a *modified task*.
PLAYER_SECTIONS = ("policies", "env", "rewards")


def tasks() -> dict[str, str]:
    """The tasks, name → one-line description, the documented scenario (``hunt-v1``) first."""
    return {name: _read(name)["description"] for name in TASK_ORDER}


def check_task(name: Any) -> str:
    """``name`` if it names a task; otherwise a ValueError listing the known ones (a TypeError
    when it is not a string)."""
    if not isinstance(name, str):
        raise TypeError(f"task must be a task's name (a string), got {type(name).__name__}")
    if name not in TASK_ORDER:
        raise ValueError(f"unknown task {name!r}: one of {', '.join(TASK_ORDER)}")
    return name


def task_params(name: str, overrides: Mapping[str, Any] | None = None) -> dict:
    """Task ``name``'s params (validated), with dotted ``overrides`` on top."""
    params = _read(check_task(name))["params"]
    if overrides:
        params = apply_overrides(params, overrides)
    return _core.validate_params(params)


def task_changes(name: str) -> dict[str, Any]:
    """What task ``name`` sets differently from the documented scenario (``hunt-v1``), as
    dotted keys → its values: the column "changes" of docs/tasks.md, computed, not kept."""
    return _diff(_read("hunt-v1")["params"], _read(check_task(name))["params"])


def outcome_changes(overrides: Mapping[str, Any]) -> list[str]:
    """The dotted override keys that change the task itself (every key outside
    :data:`PLAYER_SECTIONS`): a run with any of them plays a modified task."""
    return [k for k in overrides if str(k).split(".", 1)[0] not in PLAYER_SECTIONS]


def gym_id(name: str) -> str:
    """The Gymnasium id of task ``name``'s one-learning-target view."""
    return f"wolfpack/Escape-{check_task(name)}"


def single_target_tasks() -> list[str]:
    """The tasks with one target (those with a Gymnasium id)."""
    return [name for name in TASK_ORDER if _read(name)["params"]["world"]["targets"] == 1]


_CACHE: dict[str, dict] = {}


def _read(name: str) -> dict:
    if name not in _CACHE:
        doc = _read_yaml(TASKS_DIR / f"{name}.yaml", "task")
        if not isinstance(doc, dict) or doc.get("name") != name or not isinstance(doc.get("params"), dict):
            raise ValueError(f"task file {TASKS_DIR / f'{name}.yaml'}: needs name: {name}, description and params")
        _CACHE[name] = doc
    # A copy: callers may change what they get.
    doc = _CACHE[name]
    return {"name": doc["name"], "description": doc["description"], "params": apply_overrides(doc["params"], {})}


def _diff(base: Mapping[str, Any], other: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in other.items():
        here = base.get(key)
        if isinstance(value, dict) and isinstance(here, dict):
            out.update(_diff(here, value, f"{prefix}{key}."))
        elif value != here:
            out[f"{prefix}{key}"] = value
    return out
