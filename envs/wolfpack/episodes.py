"""Scripted episodes from Python: the engine behind ``wolfpack hunt``.

Episode ``k`` uses seed ``seed + k``; episodes run in parallel in Rust with the GIL released, and
results do not depend on the number of threads.
"""

from __future__ import annotations

import statistics
from typing import Any, Callable, Iterable

from wolfpack import _core


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
    """
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"episodes must be a positive integer, got {episodes!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise ValueError(f"threads must be a positive integer, got {threads!r}")
    params = params if params is not None else _core.default_params()
    if layout is not None:
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


def summarize(results: Iterable[dict[str, Any]], elapsed_s: float | None = None) -> dict:
    """The ``wolfpack hunt --json`` summary: episodes, capture/collision/timeout rates, the
    cornered rate (episodes ended as ``cornered``, only with ``capture.cornered``), the success
    rate (captured + cornered), ``cornered_episodes`` (episodes in which a target was ever
    cornered, whether or not that ended them), median capture steps (over captured episodes;
    ``None`` if none), mean total energy per episode, and env-steps per second (summed episode
    steps / wall time) when ``elapsed_s`` is given."""
    results = list(results)
    n = len(results)
    outcomes = [r["outcome"] for r in results]
    captured = [r["capture_step"] for r in results if r["outcome"] == "captured"]
    steps = sum(int(r["steps"]) for r in results)
    return {
        "episodes": n,
        "capture_rate": outcomes.count("captured") / n if n else 0.0,
        "collision_rate": outcomes.count("collision") / n if n else 0.0,
        "timeout_rate": outcomes.count("timeout") / n if n else 0.0,
        "cornered_rate": outcomes.count("cornered") / n if n else 0.0,
        "success_rate": (outcomes.count("captured") + outcomes.count("cornered")) / n if n else 0.0,
        "cornered_episodes": sum(r.get("cornered_step") is not None for r in results),
        "median_capture_steps": float(statistics.median(captured)) if captured else None,
        "mean_energy": float(sum(float(r["energy"].sum()) for r in results) / n) if n else 0.0,
        "env_steps_per_second": (steps / elapsed_s) if elapsed_s and elapsed_s > 0 else None,
        "total_steps": steps,
    }
