"""Scripted episodes from Python: the engine behind ``wolfpack hunt``.

Episode ``k`` uses seed ``seed + k``; episodes run in parallel in Rust with the GIL released, and
results do not depend on the number of threads.
"""

from __future__ import annotations

import statistics
from array import array
from typing import Any, Callable, Iterable

import numpy as np

from wolfpack import _core
from wolfpack._checks import check_flag, check_int, check_seed, check_threads, is_int
from wolfpack.config import check_tree


def run_episodes(
    params: dict | None,
    episodes: int,
    seed: int = 0,
    *,
    layout: dict | None = None,
    record: bool = False,
    threads: int | None = None,
    progress: Callable[[int], None] | None = None,
    chunk: int | None = None,
) -> list[dict]:
    """Runs ``episodes`` scripted episodes; returns one result dict per episode, in order.

    Each result holds ``seed``, ``outcome`` (``captured`` / ``collision`` / ``timeout``, and
    ``cornered`` with ``capture.cornered``), ``steps``, ``capture_step`` (or ``None``),
    ``target_capture_steps`` [M] (each target's, or ``None``), ``cornered_step`` (the first step
    a target was cornered, world-and-laws §1.7, or ``None``), ``wolves`` N, ``targets`` M, ``energy`` [N+M]
    (J, Σ ½ m v² per step), ``collisions`` [N+M] (steps spent overlapping), and with
    ``record=True`` a ``trajectory`` dict of arrays (see :mod:`wolfpack.logs`).

    ``progress(k)`` is called after each chunk with the number of episodes finished in it; the
    chunking does not change results.

    Episode seeds ``seed + k`` are unsigned 64-bit: ``seed + episodes - 1 < 2**64``. A wrong
    type (a str seed, a float count) is a TypeError; a bad value (a seed out of range,
    ``episodes < 1``, ``chunk`` not an integer >= 1, ``record`` not True or False, ``threads``
    outside 1..256) a ValueError naming it.
    """
    episodes = check_int(episodes, "episodes", 1)
    seed = check_seed(seed, span=episodes)
    record = check_flag(record, "record")
    threads = check_threads(threads)
    if chunk is not None and (not is_int(chunk) or chunk < 1):
        raise ValueError(f"chunk must be None or an integer >= 1, got {chunk!r}")
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be None or a callable, got {type(progress).__name__}")
    if params is not None:
        check_tree(params, "params")
    params = params if params is not None else _core.default_params()
    if layout is not None:
        check_tree(layout, "layout")
        _core.check_layout(params, layout, seed)
    if chunk is None:
        chunk = episodes if progress is None else max(1, min(episodes, 4 * (threads or 2)))
    results: list[dict] = []
    for first in range(0, episodes, chunk):
        count = min(chunk, episodes - first)
        results.extend(_core.run_episodes(params, seed, first, count, layout, record, threads))
        if progress is not None:
            progress(count)
    return results


class RunningSummary:
    """The :func:`summarize` figures, gathered one episode at a time in constant memory per
    episode (counters, plus one 4-byte capture step per captured episode for the median), so
    that ``wolfpack hunt`` over millions of episodes does not grow with them."""

    def __init__(self) -> None:
        self.episodes = 0
        self.outcomes = {"captured": 0, "collision": 0, "timeout": 0, "cornered": 0}
        self.cornered_episodes = 0
        self.capture_steps = array("i")
        self.energy = 0.0
        self.steps = 0

    def add(self, result: dict[str, Any]) -> None:
        outcome = str(result["outcome"])
        self.episodes += 1
        self.outcomes[outcome] = self.outcomes.get(outcome, 0) + 1
        if outcome == "captured":
            self.capture_steps.append(int(result["capture_step"]))
        self.cornered_episodes += result.get("cornered_step") is not None
        self.energy += float(np.sum(result["energy"]))
        self.steps += int(result["steps"])

    def summary(self, elapsed_s: float | None = None) -> dict:
        n = self.episodes
        rate = lambda k: self.outcomes[k] / n if n else 0.0  # noqa: E731
        return {
            "episodes": n,
            "capture_rate": rate("captured"),
            "collision_rate": rate("collision"),
            "timeout_rate": rate("timeout"),
            "cornered_rate": rate("cornered"),
            "success_rate": (self.outcomes["captured"] + self.outcomes["cornered"]) / n if n else 0.0,
            "cornered_episodes": self.cornered_episodes,
            "median_capture_steps": float(statistics.median(self.capture_steps)) if self.capture_steps else None,
            "mean_energy": self.energy / n if n else 0.0,
            "env_steps_per_second": (self.steps / elapsed_s) if elapsed_s and elapsed_s > 0 else None,
            "total_steps": self.steps,
        }


def summarize(results: Iterable[dict[str, Any]], elapsed_s: float | None = None) -> dict:
    """The ``wolfpack hunt --json`` summary: episodes, capture/collision/timeout rates, the
    cornered rate (episodes ended as ``cornered``, only with ``capture.cornered``), the success
    rate (captured + cornered), ``cornered_episodes`` (episodes in which a target was ever
    cornered, whether or not that ended them), median capture steps (over captured episodes;
    ``None`` if none), mean total energy per episode, and env-steps per second (summed episode
    steps / wall time) when ``elapsed_s`` is given."""
    tally = RunningSummary()
    for r in results:
        tally.add(r)
    return tally.summary(elapsed_s)
