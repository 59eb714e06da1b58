"""Policies played again for the viewer: ``wolfpack view --compare`` (each policy drives the
wolves against the scenario's targets) and the example episodes of the matrix and scorecard
pages (a wolf policy against a target policy, either a law or a saved model). Episode k is
world seed ``S + k``'s first (:func:`wolfpack.evaluation.rollout`'s numbering: the very starts
``wolfpack hunt --seed S`` plays, and those the matrix and scorecards measured), and every state
is recorded as ``trajectory.npz`` records it."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from wolfpack import _core
from wolfpack.batch import OUTCOMES, BatchEnv, first_cornered_step
from wolfpack.logs import _vertices_table, mode_arrays
from wolfpack.scorecard import as_policy
from wolfpack.sides import bring_observation, mode_key


def _kind(o: dict) -> str:
    return f"{'moving' if o['moving'] else 'static'}_{o['kind']}"


def play(policy: Any, params: dict, episodes: int, seed: int, threads: int | None = None) -> list[dict[str, np.ndarray]]:
    """``policy`` (anything :func:`wolfpack.scorecard.as_policy` takes) driving the wolves
    against the targets' law of ``params`` for ``episodes`` episodes from world seed ``seed``:
    the arrays of ``trajectory.npz`` per episode (:mod:`wolfpack.logs`)."""
    return play_pairing(policy, None, params, episodes, seed, threads)


def _drivers(wolves: Any, targets: Any, params: dict) -> tuple[dict, dict]:
    """Each side's driver (None: the law in ``params``) and the params with the laws set."""

    p = json.loads(json.dumps(params))
    sides = {side: (as_policy(who, side) if who is not None else None) for side, who in (("wolves", wolves), ("targets", targets))}
    for side, driver in sides.items():
        if driver is not None and not driver.learned:
            p["policies"][side] = driver.law
    return sides, p


def pairing_params(wolves: Any, targets: Any, params: dict) -> tuple[dict, dict[str, str]]:
    """The resolved params ``wolves`` and ``targets`` play in (a law sets its side's
    ``policies`` key) and who drives each side (a law's or a model's name), for what the page
    says about the episodes."""
    sides, p = _drivers(wolves, targets, params)
    resolved = _core.validate_params(p, resolve=True)
    return resolved, {side: (d.name if d is not None and d.learned else resolved["policies"][side]) for side, d in sides.items()}


def play_pairing(wolves: Any, targets: Any, params: dict, episodes: int, seed: int, threads: int | None = None) -> list[dict[str, np.ndarray]]:
    """``wolves`` against ``targets`` (each a law's name, a saved model, or None for the law in
    ``params``), as :func:`play`. A model plays in its own action mode and observation layout
    (as an opponent does); with a model on each side the targets' is called here, step by step,
    on their observations."""

    sides, p = _drivers(wolves, targets, params)
    learned = {side: d for side, d in sides.items() if d is not None and d.learned}
    learner = None
    if len(learned) == 2:  # one opponent per batch: the targets' model runs here
        learner = learned.pop("targets")
        if learner.action_mode is not None:
            p["env"][mode_key("targets")] = learner.action_mode
        bring_observation(p, learner.observation)
    opponent = next(iter(learned.values()), None)
    batch = BatchEnv(p, num_envs=episodes, learners="targets" if learner else "none", seed=seed, autoreset=False, threads=threads, opponent=opponent)
    out = batch.reset(seed)  # episode 0 of worlds seed + e
    n, m = batch.n_wolves, batch.n_targets
    states: list[list[dict]] = [[batch.world_state(e)] for e in range(episodes)]
    ended: list[dict | None] = [None] * episodes
    while any(x is None for x in ended):
        actions = None
        if learner is not None:
            obs = np.asarray(out["obs_targets"])
            actions = learner.act(obs.reshape(-1, obs.shape[-1])).reshape(*obs.shape[:-1], 2)
        out = batch.step(None, actions)
        for e in range(episodes):
            if ended[e] is not None:
                continue
            states[e].append(batch.world_state(e))
            if int(out["outcome"][e]) != 0:
                ended[e] = {k: np.array(v[e], copy=True) for k, v in out.items()}
    resolved = _core.validate_params(p, resolve=True)
    border = np.asarray(resolved["world"]["border"], dtype=np.float64)
    result = []
    for e in range(episodes):
        s, end = states[e], ended[e]
        shapes = s[0]["obstacles"]
        outcome = OUTCOMES[int(end["outcome"])]
        caps = np.asarray(end["capture_step"]).reshape(-1)
        cornered = first_cornered_step(end["cornered_step"])
        result.append(
            {
                "wolves": np.stack([x["wolves"] for x in s]).astype(np.float64),
                "targets": np.stack([x["targets"] for x in s]).astype(np.float64),
                "energy": np.stack([x["energy"] for x in s]).astype(np.float64),
                "interaction": np.stack([x["interaction"] for x in s[1:]]).astype(np.uint8) if len(s) > 1 else np.zeros((0, n + m, n + m), np.uint8),
                "collisions": np.asarray(end["collisions"], dtype=np.uint32),
                "outcome": np.array(outcome),
                "capture_step": np.array(int(caps.max()) if outcome == "captured" else -1, dtype=np.int64),
                "target_capture_step": np.array([int(c) if c >= 0 else -1 for c in caps], dtype=np.int64),
                "cornered_step": np.array(cornered if cornered >= 0 else -1, dtype=np.int64),
                "seed": np.array(seed + e, dtype=np.uint64),
                "obstacle_poses": np.array([[[*o["center"], o["angle"]] for o in x["obstacles"]] for x in s], dtype=np.float64).reshape(len(s), len(shapes), 3),
                "obstacle_kind": np.array([_kind(o) for o in shapes], dtype=str),
                "obstacle_radius": np.array([float(o["radius"]) for o in shapes], dtype=np.float64),
                "obstacle_vertices": _vertices_table([{"vertices": np.asarray(o["local"]).tolist()} for o in shapes]),
                "border": border,
                "ts": np.array(float(resolved["world"]["ts"])),
                "capture_distance": np.array(float(resolved["capture"]["distance"])),
                # the laws' modes (0, none, for a side a model drives)
                **mode_arrays({side: np.stack([x[side] for x in s]) for side in ("wolf_mode", "target_mode")}),
            }
        )
    return result
