"""Shared helpers for the Python tests: running the CLI, small scenarios, synthetic results."""

from __future__ import annotations

import functools
import importlib.util
import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

# tests/rllib runs in its own virtualenv (tests/rllib/run.sh: ray pins gymnasium); where ray is
# not installed it is not collected at all, so that it is never reported as skipped.
if importlib.util.find_spec("ray") is None:
    collect_ignore = ["rllib"]

REPO_ROOT = Path(__file__).resolve().parents[1]


@functools.cache
def training_script(name: str):
    """``training/NAME.py`` as a module, loaded once (the scripts import only the installed
    package, so each loads on its own, without their folder on the import path)."""
    spec = importlib.util.spec_from_file_location(f"training_{name}", REPO_ROOT / "training" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # as an import would: dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


#: Keeps end-to-end runs short: episodes end by 120 steps at the latest.
SHORT = ("--set", "world.max_steps=120")


def run_cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Runs ``wolfpack ARGS`` in a fresh interpreter (stderr is a pipe, so no progress bar)."""
    return subprocess.run([sys.executable, "-m", "wolfpack.cli", *map(str, args)], capture_output=True, text=True, timeout=timeout)


def popen_interruptible(args, **kwargs) -> subprocess.Popen:
    """``subprocess.Popen(args, **kwargs)`` whose child takes Ctrl-C as a user's process does.

    A test run started in the background (``nohup … &`` from a script, or a CI runner that
    starts its jobs so) has SIGINT ignored, and a child inherits that: Python then installs no
    KeyboardInterrupt handler, and a SIGINT the test sends does nothing. The child gets the
    default disposition back before it starts."""
    return subprocess.Popen(args, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL), **kwargs)


@pytest.fixture
def cli():
    return run_cli


def layout_dict() -> dict:
    """5 wolves, 1 target, a moving circle and a moving polygon (so seeds matter), all well
    inside the default arena and clear of each other. Headings in [0, 2π) as the core keeps
    them."""
    return {
        "wolves": [[-6.0, -6.0, 0.5], [-4.0, -6.0, 1.0], [-2.0, -6.0, 1.5], [0.0, -6.0, 2.0], [2.0, -6.0, 2.5]],
        "targets": [[0.0, 0.0, 3.0]],
        "obstacles": [
            {"kind": "circle", "center": [5.0, 5.0], "radius": 0.8, "moving": True},
            {"kind": "polygon", "center": [-5.0, 5.0], "moving": True, "vertices": [[-4.0, 5.0], [-5.0, 6.0], [-5.6, 5.6], [-6.0, 5.0], [-5.0, 4.0]]},
        ],
    }


@pytest.fixture
def layout_file(tmp_path) -> Path:
    path = tmp_path / "layout.json"
    path.write_text(json.dumps(layout_dict()))
    return path


def synthetic_result(n: int = 3, m: int = 1, steps: int = 7, seed: int = 11, outcome: str = "captured") -> dict:
    """An episode result shaped like ``_core.run_episodes(..., record=True)``'s, for testing the
    writers without running the simulator: one circle and one 5-vertex polygon."""
    rng = np.random.default_rng(seed)
    rows = steps + 1
    wolves = rng.uniform(-5, 5, (rows, n, 5))
    targets = rng.uniform(-5, 5, (rows, m, 5))
    wolves[0, :, 3:] = targets[0, :, 3:] = 0.0
    energy = np.cumsum(0.5 * np.concatenate([wolves[..., 3], targets[..., 3]], axis=1) ** 2, axis=0)
    square = [[0.5, 0.0], [0.0, 0.5], [-0.5, 0.0], [0.0, -0.5], [0.3, -0.3]]
    poses = np.tile(np.array([[3.0, 3.0, 0.0], [-3.0, 3.0, 0.0]]), (rows, 1, 1))
    poses[:, 1, 2] = np.linspace(0.0, 1.0, rows)
    return {
        "seed": seed,
        "outcome": outcome,
        "steps": steps,
        "capture_step": steps if outcome == "captured" else None,
        "wolves": n,
        "targets": m,
        "energy": energy[-1].copy(),
        "collisions": np.zeros(n + m, dtype=np.uint32),
        "trajectory": {
            "wolves": wolves,
            "targets": targets,
            "energy": energy,
            "interaction": rng.integers(0, 2, (steps, n + m, n + m)).astype(np.uint8),
            "obstacle_poses": poses,
            "obstacle_shapes": [
                {"kind": "moving_circle", "radius": 0.7, "vertices": []},
                {"kind": "static_polygon", "radius": 0.5, "vertices": square},
            ],
        },
    }
