"""The two sides' vocabulary: their names, their scripted laws, their action modes and the
learning-interface keys that belong to one side's observation (docs/interface.md). One source
for every module that names a side."""

from __future__ import annotations

from typing import Any

from wolfpack import _core

SIDES = ("wolves", "targets")
#: Each side's opponents.
OTHER_SIDE = {"wolves": "targets", "targets": "wolves"}
#: The scripted laws each side can follow, by name (the core's own lists).
SCRIPTED_LAWS: dict[str, tuple[str, ...]] = {"wolves": tuple(_core.WOLF_LAWS), "targets": tuple(_core.TARGET_LAWS)}
ACTION_MODES = ("unicycle", "velocity")
#: Who learns in a batch (``learners=``): one side, both or neither (the core's list).
LEARNERS: tuple[str, ...] = tuple(_core.LEARNERS)
#: The first name of "both", still taken wherever ``learners`` is.
LEARNERS_ALIASES = {"all": "both"}


def learners_name(learners: Any) -> Any:
    """``learners`` with an alias resolved (``"all"`` becomes ``"both"``), anything else as
    given."""
    return LEARNERS_ALIASES.get(learners, learners) if isinstance(learners, str) else learners


def check_learners(learners: Any) -> str:
    """``learners`` as the package names it (:func:`learners_name`); ValueError listing the
    names otherwise."""
    name = learners_name(learners)
    if name not in LEARNERS:
        raise ValueError(f"learners must be one of {', '.join(map(repr, LEARNERS))}, got {learners!r}")
    return name


def mode_key(side: str) -> str:
    """The params key under ``env`` of ``side``'s own action mode."""
    return "wolf_action_mode" if side == "wolves" else "target_action_mode"


#: The learning-interface keys (params ``env.*``) that shape one side's observation only: a model
#: brings its own values of its side's keys into any world it plays in.
SIDE_OBSERVATION_KEYS = {"wolves": ("last_sighting",), "targets": ()}
#: Each side's own observation layout key (``flat`` or ``entities``) under ``env``.
LAYOUT_KEY = {"wolves": "wolf_observation", "targets": "target_observation"}
#: The capacities of entity observations (``env.entities``) a model may meet larger.
ENTITY_CAPACITIES = ("max_wolves", "max_targets", "max_obstacles")


def side_observation(params: dict, side: str) -> dict:
    """``side``'s own observation keys as set in ``params`` (a model's training params; a key
    they lack is off, as in params.yaml): :data:`SIDE_OBSERVATION_KEYS`, its layout
    (``wolf_observation`` / ``target_observation``: its own, else ``observation``, else flat)
    and, for an entity layout, ``entities`` (its capacities and range)."""
    env = (params or {}).get("env") or {}
    keys: dict[str, Any] = {key: bool(env.get(key, False)) for key in SIDE_OBSERVATION_KEYS[side]}
    layout = env.get(LAYOUT_KEY[side]) or env.get("observation") or "flat"
    keys[LAYOUT_KEY[side]] = layout
    if layout == "entities":
        keys["entities"] = dict(env.get("entities") or {})
    return keys


def bring_observation(params: dict, observation: dict) -> None:
    """Sets a model's own observation keys (:func:`side_observation`) in the ``env`` section of
    ``params``, the params it plays in. Entity capacities become the largest of the model's, the
    world's and the world's team sizes: a set network reads any number of rows, and the world
    may hold more agents than the model was trained with."""
    env = params["env"]
    for key, value in observation.items():
        if key in LAYOUT_KEY.values():
            # Set only where it changes the side's layout: an unchanged layout keeps the params
            # as they were (a league swaps opponents mid-episode only while the world's params
            # stay the same).
            if value != (env.get(key) or env.get("observation") or "flat"):
                env[key] = value
            continue
        if key != "entities":
            env[key] = value
            continue
        mine = dict(env.get("entities") or {})
        merged = {**mine, **value}
        for cap in ENTITY_CAPACITIES:
            if cap in mine and cap in value:
                merged[cap] = max(int(mine[cap]), int(value[cap]))
        world = params.get("world") or {}
        for cap, count in (("max_wolves", world.get("wolves")), ("max_targets", world.get("targets"))):
            if isinstance(count, int) and cap in merged:
                merged[cap] = max(int(merged[cap]), count)
        env["entities"] = merged


def side_action_mode(params: dict, side: str) -> str:
    """How ``side`` reads its actions on ``params``: its own mode, else ``env.action_mode``."""
    env = params["env"]
    return env.get(mode_key(side)) or env["action_mode"]


def law_side(name: str) -> str | None:
    """The side whose scripted law ``name`` is (None: no law of either side)."""
    return next((side for side, laws in SCRIPTED_LAWS.items() if name in laws), None)
