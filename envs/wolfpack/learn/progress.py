"""What a training run shows while it runs: ``progress.csv`` (one row per update), the same
as TensorBoard scalars, and the progress bar."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

#: progress.csv's columns: these, then per learning side ``<side>_`` + :data:`SIDE_COLUMNS`,
#: then per side ``eval_<side>_`` + :data:`EVAL_COLUMNS` (and, multi-task, each task's).
BASE_COLUMNS = ("update", "wall_s", "agent_steps", "agent_steps_per_s", "rollout_s", "update_s", "episodes", "captured_rate", "collision_rate", "timeout_rate", "cornered_rate")
SIDE_COLUMNS = ("return", "policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction", "explained_variance", "learning_rate")
EVAL_COLUMNS = ("capture_rate", "collision_rate", "median_capture_steps")


def cell(v: Any) -> Any:
    """A value as progress.csv writes it: floats to 6 significant digits, NaN and None empty."""
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.6g}"
    return "" if v is None else v


def tensorboard(out: Path):
    """TensorBoard's writer into ``out``, or None without tensorboard installed."""
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:  # tensorboard is in the [train] extra; progress.csv has the same numbers
        return None
    return SummaryWriter(str(out))


def progress_bar(spec: Any, enabled: bool):
    """The run's bar (per mille of the budget, on stderr), or None when not ``enabled``."""
    if not enabled:
        return None
    from tqdm import tqdm

    budget = f"{spec.time_limit_min:g} min" if spec.time_limit_min else f"{spec.timesteps:,} agent-steps"
    return tqdm(total=1000, desc=f"{spec.learners} {spec.algo} ({budget})", unit="‰", bar_format="{desc}: {percentage:3.0f}%|{bar:20}| {elapsed}<{remaining} {postfix}", file=sys.stderr)


def postfix(row: dict, sides: tuple[str, ...]) -> str:
    """The bar's text after an update: throughput, outcomes and the latest held-out rates."""

    def pct(v):
        return "—" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{100 * v:.0f}%"

    text = f"{row['agent_steps_per_s'] / 1000:.0f}k agent-steps/s, captured {pct(row['captured_rate'])}, collision {pct(row['collision_rate'])}"
    for side in sides:
        if f"eval_{side}_capture_rate" in row:
            text += f", held-out {side} {pct(row[f'eval_{side}_capture_rate'])}"
    return text
