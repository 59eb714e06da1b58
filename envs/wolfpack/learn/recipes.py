"""The trainer's hyperparameter recipes (``recipes.yaml`` beside this file): one per side and
algorithm, ``default`` with the ``<side>.<algo>`` section on top, then a run's overrides."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Mapping

import yaml

from wolfpack.networks import POOLS
from wolfpack.sides import LEARNERS as BATCH_LEARNERS

RECIPES_PATH = Path(__file__).with_name("recipes.yaml")
#: What the trainer can learn: the batch's learners less "none".
LEARNERS = tuple(name for name in BATCH_LEARNERS if name != "none")
NETWORKS = ("mlp", "entities")
ALGOS = ("ippo", "mappo")
# Recipe keys that are params overrides rather than hyperparameters: the learning side's reward
# weights (params rewards.<side>.*) and the learning interface (params env.*).
PARAMS_SECTIONS = ("rewards", "env")
#: The range of ``log_std_init``.
LOG_STD_RANGE = (-20, 2)


def recipe(side: str, algo: str, overrides: Mapping[str, Any] | None = None, base: Mapping[str, Any] | None = None) -> dict:
    """The recipe of ``side`` (``wolves`` or ``targets``) and ``algo``, with ``overrides`` (keys
    of the recipe; a key it does not have is a ValueError listing the known ones). ``base``: a
    saved model's recipe that a run continues from (``--init``), laid over the table's (which
    fills the keys an older model lacks) before the overrides."""
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}: one of {', '.join(ALGOS)}")
    table = yaml.safe_load(RECIPES_PATH.read_text())
    r = dict(table["default"])
    r.update((table.get(side) or {}).get(algo) or {})
    r.update({key: value for key, value in (base or {}).items() if key in r})
    for section in PARAMS_SECTIONS:
        r[section] = dict(r.get(section) or {})
    for key, value in (overrides or {}).items():
        head, _, sub = key.partition(".")
        if head in PARAMS_SECTIONS and sub:
            r[head][sub] = value
            continue
        if key not in r:
            raise ValueError(f"--hp {key}: no such hyperparameter (known: {', '.join(sorted(r))})")
        r[key] = value
    _check(r)
    return r


def _check(r: dict) -> None:
    """Each value of the right kind and range; ValueError naming the key."""

    def need(key: str, ok: bool, what: str) -> None:
        if not ok:
            raise ValueError(f"--hp {key}: must be {what}, got {r[key]!r}")

    # Finite numbers only: an infinite or NaN learning rate, entropy weight or log σ passes a
    # bare "> 0" test and then makes every action NaN in the first update, leaving a run that
    # neither trains nor resumes.
    is_num = lambda v: isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)  # noqa: E731
    for key in ("num_envs", "n_steps", "epochs", "minibatch_size"):
        need(key, isinstance(r[key], int) and not isinstance(r[key], bool) and r[key] >= 1, "an integer >= 1")
    # Adam's step and PPO's ratio clip: beyond 1 neither means anything.
    for key in ("learning_rate", "clip"):
        need(key, is_num(r[key]) and 0 < r[key] <= 1, "a number in (0, 1]")
    need("max_grad_norm", is_num(r["max_grad_norm"]) and r["max_grad_norm"] > 0, "a finite number > 0")
    for key in ("gamma", "gae_lambda"):
        need(key, is_num(r[key]) and 0 <= r[key] <= 1, "a number in [0, 1]")
    need("ent_coef", is_num(r["ent_coef"]) and 0 <= r["ent_coef"] <= 1, "a number in [0, 1]")
    need("vf_coef", is_num(r["vf_coef"]) and r["vf_coef"] >= 0, "a finite number >= 0")
    for key in ("clip_value", "target_kl"):
        need(key, r[key] is None or (is_num(r[key]) and r[key] > 0), "null or a finite number > 0")
    # The Gaussian's log σ at the start, on actions in [-1, 1]: σ from 2e-9 to e^2 = 7.4.
    need("log_std_init", is_num(r["log_std_init"]) and LOG_STD_RANGE[0] <= r["log_std_init"] <= LOG_STD_RANGE[1], f"a number in [{LOG_STD_RANGE[0]}, {LOG_STD_RANGE[1]}]")
    need(
        "hidden",
        isinstance(r["hidden"], list) and len(r["hidden"]) >= 1 and all(isinstance(h, int) and not isinstance(h, bool) and h >= 1 for h in r["hidden"]),
        "a list of layer widths, e.g. [64, 64]",
    )
    need("activation", r["activation"] in ("tanh", "relu"), "'tanh' or 'relu'")
    need("network", r["network"] in NETWORKS, " or ".join(repr(n) for n in NETWORKS))
    need("pool", r["pool"] in POOLS, " or ".join(repr(n) for n in POOLS))
    for key in ("entity_width", "heads"):
        need(key, isinstance(r[key], int) and not isinstance(r[key], bool) and 1 <= r[key] <= 4096, "an integer in [1, 4096]")
    need("entity_width", r["entity_width"] % r["heads"] == 0, f"a multiple of heads ({r['heads']})")
    # A one-hot agent id ties the model to one team size, what the set network is for undoing.
    need("agent_id", not (r["agent_id"] and r["network"] == "entities"), "false with network: entities (an agent id ties the model to one team size)")
    for key in ("anneal_lr", "agent_id", "norm_obs", "norm_reward"):
        need(key, isinstance(r[key], bool), "true or false")
    need("rewards", isinstance(r["rewards"], dict), "a mapping of the side's reward keys")
    need("env", isinstance(r["env"], dict), "a mapping of learning-interface keys (params env.*)")


def recipes_params_overrides(recipes: Mapping[str, dict]) -> dict:
    """The params overrides of every side's recipe (``{side: recipe}``) together; two recipes
    that set one key differently are a ValueError naming it."""
    merged: dict = {}
    for side, r in recipes.items():
        for key, value in params_overrides(side, r).items():
            if merged.get(key, value) != value:
                raise ValueError(f"the recipes of both sides set {key} differently ({merged[key]!r}, {value!r}): choose with --set {key}=...")
            merged[key] = value
    return merged


def params_overrides(side: str, r: dict) -> dict:
    """The recipe's params overrides: its reward weights (``rewards.<side>.<key>``) and its
    learning-interface keys (``env.<key>``). Neither changes the world or how an episode ends
    (weights change what the learner is paid, env keys what it observes), so a model trained
    with them is evaluated on the same outcomes as any other; the saved model's params carry
    them, so it is loaded with the observation it was trained on."""
    overrides = {**{f"rewards.{side}.{k}": v for k, v in r["rewards"].items()}, **{f"env.{k}": v for k, v in r["env"].items()}}
    if r["network"] == "entities":
        # The set network reads entity rows: its side observes them, and the state (MAPPO's
        # critic) takes the same form.
        overrides.setdefault(f"env.{OBSERVATION_KEY[side]}", "entities")
        overrides.setdefault("env.state", "entities")
    return overrides


#: The params key under ``env`` of each side's own observation layout.
OBSERVATION_KEY = {"wolves": "wolf_observation", "targets": "target_observation"}


def rollout_bytes(r: Mapping[str, Any], *, agents: int, obs_dim: int, state_dim: int, centralised: bool) -> int:
    """The bytes of one learning side's rollout buffers (float32, allocated when training
    starts): per world-step and agent its observation, action (2), log-probability, value,
    reward, advantage and return, per world-step the done flag and, centralised, the state."""
    per_world_step = agents * (obs_dim + 7) + 1 + (state_dim if centralised else 0)
    return 4 * int(r["num_envs"]) * int(r["n_steps"]) * per_world_step


def available_memory() -> int | None:
    """Bytes of memory this machine can give a new allocation now (Linux's MemAvailable, else
    its physical memory); None where neither is known."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return None


def check_memory(r: Mapping[str, Any], needed: int, available: int | None = None) -> None:
    """ValueError naming ``num_envs`` and ``n_steps`` when the rollout buffers (``needed``
    bytes, :func:`rollout_bytes` of every learning side) exceed the memory ``available`` (default
    :func:`available_memory`): refused before anything is written, rather than an allocation
    failing once the run folder exists."""
    available = available_memory() if available is None else available
    if available is not None and needed > available:
        raise ValueError(
            f"--hp num_envs x n_steps: the rollout buffers of {int(r['num_envs']):,} worlds x {int(r['n_steps']):,} steps take "
            f"{needed / 2**30:,.1f} GiB, more than the {available / 2**30:,.1f} GiB of memory available here; lower num_envs or n_steps"
        )
