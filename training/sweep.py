"""What the sweep scripts (task_baselines.py, exploitability.py) share: one ``wolfpack train``
run per child process, and a finished run's held-out evaluation cached in its folder.

A child process per run gives every run a fresh torch and core thread pool and the machine to
itself (runs go one after another), and a crash ends the sweep with the failing command on
stderr instead of leaving a half-written row.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Sequence

#: The file in a run folder that holds its held-out evaluation.
HELD_OUT_FILE = "held_out.json"


def train_once(folder: Path, options: Sequence[str]) -> dict:
    """The summary of the ``wolfpack train OPTIONS --out folder`` run in ``folder``: read back when
    the run finished before (its ``summary.json`` exists), else trained now in a child process
    (a folder left by an interrupted run is cleared first). Logs each command with the time."""
    summary = folder / "summary.json"
    if not summary.exists():
        if folder.exists():
            shutil.rmtree(folder)
        cmd = [sys.executable, "-m", "wolfpack.cli", "train", *options, "--no-progress", "--out", str(folder)]
        print(f"[{time.strftime('%H:%M:%S')}] {' '.join(cmd[2:])}", file=sys.stderr, flush=True)
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return json.loads(summary.read_text())


def held_out(folder: Path, episodes: int, evaluate: Callable[[], dict], reevaluate: bool = False) -> dict:
    """``evaluate()``'s row for the run in ``folder``, cached in its ``held_out.json`` with the
    episode count; recomputed when the count differs or ``reevaluate`` (after a change to the
    core, which moves every trajectory)."""
    cache = folder / HELD_OUT_FILE
    if cache.exists() and not reevaluate:
        row = json.loads(cache.read_text())
        if row.get("episodes") == episodes:
            return row
    row = {"episodes": episodes, **evaluate()}
    cache.write_text(json.dumps(row, indent=1) + "\n")
    return row
