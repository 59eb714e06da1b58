"""Learned results over training seeds (``training/seeds.py``): the curves of the held-out
evaluations during training, median over seeds with their range."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml


def median_capture_step(rows: list[dict]) -> float | None:
    """The median over seeds of each seed's median capture step (None: no seed captured)."""
    steps = [r["median_capture_steps"] for r in rows if r["median_capture_steps"] is not None]
    return float(np.median(steps)) if steps else None


def skill(side: str, row: dict) -> float:
    return row["capture_rate"] if side == "wolves" else row["survival_rate"]


def curves(out: Path, runs: list[Path], side: str, axis: str = "minutes", opponent: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    series = []
    for run in runs:
        evals = [e for e in json.loads((run / "evaluations.json").read_text()) if e.get("phase", "ppo") == "ppo"]
        x = [e["train_s"] / 60 for e in evals] if axis == "minutes" else [e["agent_steps"] / 1e6 for e in evals]
        series.append((np.array(x), np.array([skill(side, e[side]) for e in evals]), np.array([e[side]["collision_rate"] for e in evals])))
    grid = np.linspace(max(s[0][0] for s in series), min(s[0][-1] for s in series), 60)
    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    what = "captured (held-out)" if side == "wolves" else "survived (held-out)"
    for k, (label, colour) in enumerate(((what, "tab:blue"), ("wolf collisions", "tab:red"))):
        ys = np.array([np.interp(grid, t, v, left=np.nan) for t, *vals in series for v in [vals[k]]])
        ax.plot(grid, 100 * np.nanmedian(ys, axis=0), color=colour, label=f"{label}: median of {len(series)} seeds")
        ax.fill_between(grid, 100 * np.nanmin(ys, axis=0), 100 * np.nanmax(ys, axis=0), color=colour, alpha=0.2, label=f"{label}: range")
    ax.set_xlabel("training wall time (min, evaluations excluded)" if axis == "minutes" else "agent-steps trained (millions)")
    ax.set_ylabel("% of held-out episodes")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center right")
    against = f" against {opponent}" if opponent else ""
    algos = sorted({str((yaml.safe_load((run / "config.yaml").read_text()) or {}).get("algo", "?")).upper() for run in runs})
    ax.set_title(f"{side} ({', '.join(algos)}){against}: {len(series)} training seeds,\n{series[0][0].size} evaluations each on held-out episodes", fontsize=10)
    fig.savefig(out / "curves.png", dpi=120)
    plt.close(fig)
