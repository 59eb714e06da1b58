"""Multi-task training's worlds: which tasks, which variations of them, and the groups of worlds
the trainer's batch is split into (``wolfpack train --task A --task B``, ``--task all``,
``--vary KEY=LO:HI``).

A batch holds worlds of one params, so each group of worlds is a batch of its own, stepped in
turn by the trainer: one group per task, or with ``--vary`` :data:`VARIANTS` groups per task,
each drawing every varied key once (uniformly in its range; integers for an integer key) from
the run's seed. The held-out evaluations play each task as it is, without the variations.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from wolfpack.task import TASK_ORDER

#: Groups of worlds per task when keys vary.
VARIANTS = 4
#: The task list that stands for every task of the suite.
ALL = "all"
#: How the tasks weigh in the update (``--task-weights``; docs/interface.md): equally, or after
#: each held-out evaluation by the learner's failure rate on each (``adaptive``) or by how far
#: it is below each task's best committed law (``shortfall``).
TASK_WEIGHTS = ("uniform", "adaptive", "shortfall")


def task_list(names: Sequence[str] | None) -> list[str]:
    """The tasks named (``all``: the whole suite, in its order), each once; ValueError naming an
    unknown one."""
    out: list[str] = []
    for name in names or []:
        if name == ALL:
            out.extend(TASK_ORDER)
        elif name in TASK_ORDER:
            out.append(name)
        else:
            raise ValueError(f"--task {name!r}: no such task (the suite: {', '.join(TASK_ORDER)}, or {ALL})")
    return list(dict.fromkeys(out))


def parse_vary(texts: Sequence[str]) -> dict[str, tuple[float, float]]:
    """``["world.wolves=3:8"]`` → ``{"world.wolves": (3, 8)}``; ValueError naming the text that
    is not ``KEY=LO:HI`` with numbers LO ≤ HI."""
    vary: dict[str, tuple[float, float]] = {}
    for text in texts:
        key, sep, span = str(text).partition("=")
        lo, colon, hi = span.partition(":")
        try:
            bounds = (float(lo), float(hi)) if sep and colon and key.strip() else None
        except ValueError:
            bounds = None
        if bounds is None or not all(np.isfinite(bounds)):
            raise ValueError(f"--vary {text!r}: expected KEY=LO:HI with two numbers, e.g. world.wolves=3:8")
        if bounds[0] > bounds[1]:
            raise ValueError(f"--vary {key.strip()}: the lower bound {lo} exceeds the upper bound {hi}")
        vary[key.strip()] = bounds
    return vary


def _leaf(params: Mapping[str, Any], key: str) -> Any:
    node: Any = params
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            raise ValueError(f"--vary {key}: no such params key")
        node = node[part]
    return node


def drawable_range(params: Mapping[str, Any], key: str, lo: float, hi: float) -> tuple[float, float] | tuple[int, int]:
    """The values ``key`` can be drawn between in [LO, HI]: the range itself, or for an integer
    key the integers in it (ValueError naming a key that is not a number, or an integer key
    with no integer in range)."""
    current = _leaf(params, key)
    if isinstance(current, bool) or not isinstance(current, (int, float)):
        raise ValueError(f"--vary {key}: not a numeric key (it is {current!r})")
    if isinstance(current, int):
        ilo, ihi = int(np.ceil(lo)), int(np.floor(hi))
        if ilo > ihi:
            raise ValueError(f"--vary {key}: an integer key, and no integer lies in [{lo:g}, {hi:g}]")
        return ilo, ihi
    return lo, hi


def vary_values(params: Mapping[str, Any], vary: Mapping[str, tuple[float, float]], rng: np.random.Generator) -> dict[str, Any]:
    """One draw of every varied key within its :func:`drawable_range`: uniform, an integer for
    an integer key."""
    drawn: dict[str, Any] = {}
    for key, (lo, hi) in vary.items():
        a, b = drawable_range(params, key, lo, hi)
        drawn[key] = int(rng.integers(a, b + 1)) if isinstance(a, int) else float(rng.uniform(a, b))
    return drawn


def world_groups(tasks: Sequence[str], vary: Mapping[str, tuple[float, float]], seed: int, resolve) -> tuple[list[tuple[str, str, dict]], list[tuple[str, dict]]]:
    """(groups, eval_tasks) for the trainer: ``(label, task, params)`` per group of worlds and
    ``(task, params)`` per held-out task. ``resolve(task, extra)`` gives the validated params of
    ``task`` with the run's overrides and ``extra`` on top (a ValueError names a bad key or
    value; each range end of ``vary`` is checked that way, so that a bound outside a key's
    limits fails before anything is drawn)."""
    eval_tasks = [(task, resolve(task, {})) for task in tasks]
    groups: list[tuple[str, str, dict]] = []
    rng = np.random.default_rng([seed, 0x7A5C])
    for task, params in eval_tasks:
        if not vary:
            groups.append((task, task, params))
            continue
        for key, (lo, hi) in vary.items():  # each end of each range is a valid value on its own
            for end in drawable_range(params, key, lo, hi):
                resolve(task, {key: end})
        for v in range(VARIANTS):
            groups.append((f"{task}#{v}", task, resolve(task, vary_values(params, vary, rng))))
    return groups, eval_tasks
