"""What ``wolfpack view`` reads: run folders of ``wolfpack hunt --out`` (every
``episode_NNN/trajectory.npz`` in them), episode folders, and ``trajectory.npz`` files.

Every file is checked (:func:`wolfpack.logs.check_trajectory`) before anything is written, and
a problem is a ValueError of one line naming the file: a folder with no trajectories, a
truncated or foreign npz.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from wolfpack import _core, logs

_EPISODE_FOLDER = re.compile(r"episode_(\d{3,})")


@dataclass
class Recorded:
    """One episode read from disk: its arrays, the params of its run (for body size and sensing
    radii: the run's summary.json, else the documented scenario) and a label."""

    arrays: dict[str, np.ndarray]
    params: dict[str, Any]
    label: str
    path: Path


def _run_params(run: Path) -> dict[str, Any] | None:
    """The resolved params in ``run/summary.json``, or None (no summary, or not readable)."""
    try:
        return _core.validate_params(json.loads((run / logs.SUMMARY_NAME).read_text(encoding="utf-8"))["params"], resolve=True)
    except (OSError, ValueError, KeyError, TypeError):
        return None


def read_npz(npz: Path) -> dict[str, np.ndarray]:
    """The checked arrays of one ``trajectory.npz``; ValueError of one line otherwise."""
    try:
        arrays = logs.load_trajectory(npz)
    except Exception as e:  # zip and npy errors of every kind: not a trajectory
        detail = " ".join(str(e).split()) or type(e).__name__
        raise ValueError(f"{npz}: not a readable trajectory.npz (truncated or not an npz: {type(e).__name__}: {detail})") from None
    try:
        logs.check_trajectory(arrays)
    except ValueError as e:
        raise ValueError(f"{npz}: {e}") from None
    return arrays


def episode_files(where: Path) -> list[Path]:
    """The trajectory files ``where`` names: itself (a file), its ``trajectory.npz`` (an episode
    folder), or its episodes' in order (a run folder)."""
    if not where.exists():
        raise ValueError(f"{where}: no such file or folder")
    if where.is_file():
        return [where]
    if (where / "trajectory.npz").is_file():
        return [where / "trajectory.npz"]
    found = sorted((int(m.group(1)), child / "trajectory.npz") for child in where.iterdir() if (m := _EPISODE_FOLDER.fullmatch(child.name)) and (child / "trajectory.npz").is_file())
    if not found:
        raise ValueError(f"{where}: no trajectories there (neither a trajectory.npz nor episode_NNN/trajectory.npz folders, which 'wolfpack hunt --out DIR' writes)")
    return [path for _, path in found]


def _label(npz: Path, arrays: dict[str, np.ndarray]) -> str:
    folder = npz.parent if npz.name == "trajectory.npz" else npz
    name = f"{folder.parent.name}/{folder.name}" if npz.name == "trajectory.npz" else npz.name
    return f"{name} (seed {int(np.asarray(arrays['seed']))})" if "seed" in arrays else name


def collect(paths: Sequence[str | Path], episodes: int | None = None) -> list[Recorded]:
    """The episodes of every path in order (at most ``episodes`` of each run folder)."""
    out: list[Recorded] = []
    for where in map(Path, paths):
        files = episode_files(where)
        if episodes is not None and where.is_dir() and len(files) > 1:
            files = files[:episodes]
        for npz in files:
            arrays = read_npz(npz)
            run = npz.parent.parent if npz.name == "trajectory.npz" else npz.parent
            params = _run_params(run) or _run_params(npz.parent) or _core.validate_params(None, resolve=True)
            out.append(Recorded(arrays, params, _label(npz, arrays), npz))
    return out


def scenario_key(arrays: dict[str, np.ndarray]) -> tuple:
    """What two recordings must share to be the same episode start played two ways: arena,
    Ts, capture distance, team sizes, the obstacles' kinds and shapes and every pose at step
    0."""
    first = lambda k: np.asarray(arrays[k])  # noqa: E731
    return (
        tuple(np.round(first("border"), 6)),
        round(float(first("ts")), 9),
        round(float(first("capture_distance")), 9),
        first("wolves").shape[1],
        first("targets").shape[1],
        tuple(str(k) for k in first("obstacle_kind")),
        np.round(first("obstacle_radius"), 6).tobytes(),
        np.round(np.nan_to_num(first("obstacle_vertices"), nan=1e9), 6).tobytes(),
        np.round(first("obstacle_poses")[0], 6).tobytes(),
        np.round(first("wolves")[0, :, :3], 6).tobytes(),
        np.round(first("targets")[0, :, :3], 6).tobytes(),
    )
