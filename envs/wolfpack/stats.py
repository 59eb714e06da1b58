"""Statistics over training seeds, as the field reports learned results: the interquartile mean
(IQM) with a 95 % percentile bootstrap interval, the median and the range (Agarwal et al.,
"Deep RL at the edge of the statistical precipice"; scipy's ``trim_mean`` and ``bootstrap``)."""

from __future__ import annotations

from typing import Sequence

import numpy as np


def iqm_interval(values: Sequence[float], resamples: int = 10_000) -> dict:
    """``{"iqm", "ci95": [lo, hi], "median", "min", "max", "n"}`` of ``values`` (one per seed).
    The bootstrap's generator is seeded, so the same values give the same interval; one value,
    or values all equal, give an interval of that value."""
    from scipy import stats

    x = np.asarray(values, dtype=float)
    iqm = float(stats.trim_mean(x, 0.25))
    if len(x) > 1 and np.ptp(x) > 0:
        boot = stats.bootstrap((x,), lambda a, axis: stats.trim_mean(a, 0.25, axis=axis), confidence_level=0.95, n_resamples=resamples, method="percentile", rng=np.random.default_rng(0))
        lo, hi = float(boot.confidence_interval.low), float(boot.confidence_interval.high)
    else:
        lo = hi = iqm
    return {"iqm": iqm, "ci95": [lo, hi], "median": float(np.median(x)), "min": float(x.min()), "max": float(x.max()), "n": int(len(x))}


def iqm_cell(summary: dict) -> str:
    """``95.5 % [95.0, 96.8]``: an ``iqm_interval`` as seeds.md and RESULTS.md print it."""
    return f"{100 * summary['iqm']:.1f} % [{100 * summary['ci95'][0]:.1f}, {100 * summary['ci95'][1]:.1f}]"


def seed_rates_cell(per_seed: Sequence[dict]) -> str:
    """``16.0, 5.0, 19.5``: each seed's ``rate`` in %, in seed order (an exploitability
    budget's ``per_seed`` rows)."""
    return ", ".join(f"{100 * r['rate']:.1f}" for r in per_seed)


def range_cell(summary: dict) -> str:
    """``95.0 % (95.0–97.0)``: the median over seeds and their range."""
    return f"{100 * summary['median']:.1f} % ({100 * summary['min']:.1f}–{100 * summary['max']:.1f})"
