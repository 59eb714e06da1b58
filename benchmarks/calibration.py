"""How many steps a measurement takes: one rule for every contender, whether it runs in this
process (peer_contenders.py) or in a peer's worker in its own virtualenv (peer_worker.py).
Standard library only, so that both environments import it."""

from __future__ import annotations

import math
from typing import Callable


def calibrate(run: Callable[[int], tuple[int, float]], target_s: float, min_steps: int = 1, max_steps: int = 10_000_000) -> int:
    """After one warm-up step, times runs of 1, 4, 16, ... steps until one takes ≥ target_s / 4
    (they warm up too), then returns the step count for about ``target_s`` seconds."""
    run(1)  # a first step can be slow (allocation, caches): warm up before timing anything
    n = 1
    while True:
        _, secs = run(n)
        if secs >= target_s / 4 or n >= max_steps:
            break
        n = min(max_steps, n * 4 if secs < target_s / 40 else max(n + 1, math.ceil(n * target_s / 4 / max(secs, 1e-9))))
    return int(max(min_steps, min(max_steps, round(target_s * n / max(secs, 1e-9)))))
