"""The generalisation track of ``wolfpack benchmark --track generalisation``: variations of
``hunt-v1`` that no task file contains, to score a policy on worlds it was not built for
(docs/tasks.md, "The generalisation track").

Each variation is ``hunt-v1`` with a few keys changed; the policy plays the same held-out
episodes as on the task suite, and the three analytic laws are scored beside it on the same
episodes of the same variation (there are no committed baselines for them: the laws are run
live, so the comparison holds whatever the version).
"""

from __future__ import annotations

from typing import Any, Mapping

from wolfpack.task import task_params

#: The task every variation changes.
BASE_TASK = "hunt-v1"

#: name → (what it changes, the keys). Obstacle counts keep hunt-v1's mix (circles and polygons
#: 1 : 5, half of each moving) at 20 and 48.
VARIATIONS: dict[str, tuple[str, dict[str, Any]]] = {
    "pack-4": ("a pack of 4 wolves, all 4 needed for a capture", {"world.wolves": 4}),
    "pack-7": ("a pack of 7 wolves (6 needed)", {"world.wolves": 7}),
    "three-targets": ("3 escaping targets, all to be captured", {"world.targets": 3}),
    "obstacles-20": ("20 obstacles", {"obstacles.static_circles": 2, "obstacles.moving_circles": 2, "obstacles.static_polygons": 8, "obstacles.moving_polygons": 8}),
    # 48 of hunt-v1's sizes (or cluttered-v1's) do not fit the arena: smaller ones, 1 m apart.
    "obstacles-48": (
        "48 smaller obstacles (circles 0.2–0.7 m, polygons 0.3–0.7 m), 1 m clear at the start",
        {
            "obstacles.static_circles": 4,
            "obstacles.moving_circles": 4,
            "obstacles.static_polygons": 20,
            "obstacles.moving_polygons": 20,
            "obstacles.circle_radius": [0.2, 0.7],
            "obstacles.polygon_size": [0.3, 0.7],
            "world.init_clearance": 1.0,
        },
    ),
    "arena-30": ("a 30 m arena", {"world.border": [-15.0, -15.0, 15.0, 15.0]}),
    "target-1.75": ("a target at 1.75 m/s (the wolves' 1.5)", {"agents.target.v_max": 1.75}),
    "target-1.2": ("a target at 1.2 m/s", {"agents.target.v_max": 1.2}),
}
#: The track's name for the variations, in order.
VARIATION_ORDER = tuple(VARIATIONS)


def check_variation(name: str) -> str:
    if name not in VARIATIONS:
        raise ValueError(f"no variation {name!r} in the generalisation track (it has: {', '.join(VARIATION_ORDER)})")
    return name


def variation_params(name: str, overrides: Mapping[str, Any] | None = None) -> dict:
    """The validated params of variation ``name``, with ``overrides`` on top."""
    return task_params(BASE_TASK, {**VARIATIONS[check_variation(name)][1], **dict(overrides or {})})
