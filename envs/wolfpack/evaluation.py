"""Evaluating policies on identical episodes: the engine behind ``training/evaluate.py``, the
trainer's held-out evaluations and the league.

Episode ``k`` of an evaluation with seed ``S`` is world ``S + k``'s first episode: the very
episode ``wolfpack hunt --seed S`` runs as its k-th, so a scripted pairing here reproduces
``wolfpack hunt`` exactly and two policies evaluated with the same seed meet the same starts.
"""

from __future__ import annotations

import math
import statistics
from typing import Any, Callable

import numpy as np

from wolfpack.batch import OUTCOMES, BatchEnv, first_cornered_step
from wolfpack.episodes import summarize

#: World seeds, disjoint by construction so that "held-out" means held out: evaluations with
#: seed S play worlds S, S+1, ... (``wolfpack hunt --seed S``); training run ``--seed s`` plays
#: worlds ``TRAIN_SEED_BASE·(s+1) + e``; imitation ``IMITATION_SEED_BASE·(s+1) + e``; the
#: held-out evaluations during training ``HELD_OUT_SEED + k``.
TRAIN_SEED_BASE = 1_000_000
IMITATION_SEED_BASE = 100_000_000
HELD_OUT_SEED = 500_000

Policy = Callable[[np.ndarray], np.ndarray]


def wilson_interval(successes: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """The Wilson score interval for a binomial proportion (95 % for the default z): unlike the
    normal approximation it stays inside [0, 1] and is sound at 0 % and 100 %."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


def rollout(
    params: dict,
    *,
    episodes: int,
    seed: int,
    wolves: Policy | None = None,
    targets: Policy | None = None,
    threads: int | None = 1,
    opponent: Any = None,
    chunk: int = 256,
    progress: Callable[[int], None] | None = None,
) -> list[dict]:
    """Runs episodes ``seed .. seed + episodes − 1`` (episode k is world ``seed + k``'s first
    episode, the very episode ``wolfpack hunt --seed seed`` runs as its k-th) with the given
    policies for the learning sides and the scripted laws of ``params`` for the others (or, when
    one side is given a policy, ``opponent`` for the other: anything ``BatchEnv(opponent=)`` takes).

    Returns one dict per episode with ``wolfpack.summarize``'s fields (``seed``, ``outcome``,
    ``steps``, ``capture_step``, ``cornered_step`` (first step a target was cornered, or None),
    ``energy`` [N+M], ``collisions`` [N+M]), ``targets_captured`` (how many of the M targets
    were captured, whatever the outcome) and ``return_wolves`` /
    ``return_targets`` (undiscounted episode return per agent, averaged over the side's agents)
    and ``target_wall_distance`` (m, the targets' distance to the nearest wall when the episode
    ended, averaged over targets).
    """
    learners = {(False, False): "none", (True, False): "wolves", (False, True): "targets", (True, True): "both"}[(wolves is not None, targets is not None)]
    results: list[dict] = []
    for first in range(0, episodes, chunk):
        count = min(chunk, episodes - first)
        batch = BatchEnv(params, num_envs=count, learners=learners, seed=seed + first, autoreset=False, threads=threads, opponent=opponent)
        out = batch.reset(seed + first)  # episode 0 of worlds seed+first+e (reset(None) would go on to episode 1)
        ret_w = np.zeros((count, batch.n_wolves))
        ret_t = np.zeros((count, batch.n_targets))
        while True:
            wa = wolves(out["obs_wolves"]) if wolves is not None else None
            ta = targets(out["obs_targets"]) if targets is not None else None
            out = batch.step(wa, ta)
            ret_w += out["rewards_wolves"]
            ret_t += out["rewards_targets"]
            if (out["outcome"] != 0).all():
                break
        x0, y0, x1, y1 = params["world"]["border"]
        for e in range(count):
            final = batch.world_state(e)["targets"]
            wall = np.minimum.reduce([final[:, 0] - x0, x1 - final[:, 0], final[:, 1] - y0, y1 - final[:, 1]])
            outcome = OUTCOMES[int(out["outcome"][e])]
            caps = out["capture_step"][e]
            cornered = first_cornered_step(out["cornered_step"][e])
            results.append(
                {
                    "seed": seed + first + e,
                    "outcome": outcome,
                    "steps": int(out["steps"][e]),
                    "capture_step": int(caps.max()) if outcome == "captured" else None,
                    "targets_captured": int((caps >= 0).sum()),
                    "cornered_step": cornered if cornered >= 0 else None,
                    "energy": out["energy"][e].copy(),
                    "collisions": out["collisions"][e].copy(),
                    "n_wolves": batch.n_wolves,
                    "return_wolves": float(ret_w[e].mean()),
                    "return_targets": float(ret_t[e].mean()),
                    "target_wall_distance": float(wall.mean()),
                }
            )
        if progress is not None:
            progress(count)
    return results


def report(results: list[dict], wolves: str, targets: str) -> dict:
    """One evaluation row: the ``wolfpack hunt --json`` summary of these episodes plus the
    capture rate's 95 % Wilson interval, mean capture steps, wolf/target collision rates, the
    cornered rate (episodes ended as cornered, only with ``capture.cornered``), the success
    rate (captured + cornered), the episodes in which a target was ever cornered, mean
    returns, and with several targets how far the pack got (``any_capture_rate``: episodes in
    which at least one target was captured; ``mean_targets_captured``); ``wolves``/``targets``
    name the policies."""
    s = summarize(results)
    n = len(results)
    captured = [r["capture_step"] for r in results if r["outcome"] == "captured"]
    lo, hi = wilson_interval(len(captured), n)
    n_wolves = results[0]["n_wolves"] if results else 0
    return {
        "wolves": wolves,
        "targets": targets,
        "episodes": n,
        "first_seed": results[0]["seed"] if results else None,
        "capture_rate": s["capture_rate"],
        "capture_rate_ci95": [lo, hi],
        "survival_rate": 1.0 - s["capture_rate"],
        "median_capture_steps": s["median_capture_steps"],
        "mean_capture_steps": float(statistics.fmean(captured)) if captured else None,
        "collision_rate": s["collision_rate"],
        "target_collision_rate": sum(bool(r["collisions"][n_wolves:].any()) for r in results) / n if n else 0.0,
        "timeout_rate": s["timeout_rate"],
        "cornered_rate": s["cornered_rate"],
        "success_rate": s["success_rate"],
        "cornered_episodes": s["cornered_episodes"],
        "ever_cornered_rate": s["cornered_episodes"] / n if n else 0.0,
        "mean_energy": s["mean_energy"],
        "mean_return_wolves": float(statistics.fmean(r["return_wolves"] for r in results)) if n else 0.0,
        "mean_return_targets": float(statistics.fmean(r["return_targets"] for r in results)) if n else 0.0,
        "median_final_target_wall_distance": float(statistics.median(r["target_wall_distance"] for r in results)) if n else None,
        "any_capture_rate": sum(r["targets_captured"] > 0 for r in results) / n if n else 0.0,
        "mean_targets_captured": float(statistics.fmean(r["targets_captured"] for r in results)) if n else 0.0,
        "capture_steps": captured,
    }


#: The columns of a cross-play matrix's cell (``training/evaluate.py --matrix``): a report's
#: rates, intervals and means, without its per-episode lists.
MATRIX_KEYS = (
    "wolves",
    "targets",
    "episodes",
    "first_seed",
    "capture_rate",
    "capture_rate_ci95",
    "survival_rate",
    "median_capture_steps",
    "mean_capture_steps",
    "collision_rate",
    "target_collision_rate",
    "timeout_rate",
    "cornered_rate",
    "success_rate",
    "ever_cornered_rate",
    "mean_energy",
    "mean_return_wolves",
    "mean_return_targets",
    "median_final_target_wall_distance",
)
