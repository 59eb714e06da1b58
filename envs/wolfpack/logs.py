"""Output files of ``wolfpack hunt --out DIR`` (world-and-laws §1.7 logs).

Layout of ``DIR``::

    DIR/summary.json                       written last (temp name, then rename)
    DIR/summary.png                        outcome counts + capture-step histogram
    DIR/episode_{k:03d}/trajectory.npz     per-step logs of episode k (seed = seed + k)
    DIR/episode_{k:03d}/trajectory.png     paths (episodes k < --plots)
    DIR/episode_{k:03d}/curves.png         speeds, turn rates, wolf–target distances, energy
                                           (k < --plots)
    DIR/episode_{k:03d}/interaction.png    the interaction graph over time (k < --plots)
    DIR/episode_{k:03d}/episode.mp4        the hunt as a video (--video, k < --plots)

``trajectory.npz`` (T = steps taken, N wolves, M targets, K obstacles; SI units, radians):

=====================  ===================  ================================================
key                    dtype, shape         meaning
=====================  ===================  ================================================
``wolves``             float64 [T+1, N, 5]  x, y, θ, v, ω; row 0 the initial state (v = ω = 0),
                                            row t the state after step t
``targets``            float64 [T+1, M, 5]  as ``wolves``
``energy``             float64 [T+1, N+M]   accumulated Σ ½ m v² (J) per agent, wolves first;
                                            row 0 is 0
``interaction``        uint8 [T, N+M, N+M]  0/1 per step; row = observer, column = observed
``outcome``            str scalar           ``captured`` / ``collision`` / ``timeout`` /
                                            ``cornered`` (only with ``capture.cornered``)
``capture_step``       int64 scalar         step of the (last) capture, -1 if none
``target_capture_step`` int64 [M]           the step each target's hunt ended (captured, or
                                            cornered where that counts), -1 if it did not;
                                            from that step on it is drawn as captured
``cornered_step``      int64 scalar         first step at which a target was cornered
                                            (world-and-laws §6), -1 if none ever was
``seed``               uint64 scalar        the episode's seed
``obstacle_poses``     float64 [T+1, K, 3]  centre x, y and rotation angle
``obstacle_kind``      str [K]              static_circle, moving_circle, static_polygon,
                                            moving_polygon
``obstacle_radius``    float64 [K]          radius (bounding radius for polygons)
``obstacle_vertices``  float64 [K, V, 2]    polygon vertices relative to the centre at angle
                                            0, NaN-padded to the largest V; all NaN for
                                            circles. World vertices at step t:
                                            centre + R(angle) · local
``border``             float64 [4]          arena [x_min, y_min, x_max, y_max]
``ts``                 float64 scalar       sampling time (s)
``capture_distance``   float64 scalar       capture radius (m)
=====================  ===================  ================================================
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np

SUMMARY_NAME = "summary.json"


def episode_dir(out: Path, k: int) -> Path:
    """``out/episode_{k:03d}``: the folder of the run's k-th episode (seed = seed + k)."""
    return Path(out) / f"episode_{k:03d}"


def _vertices_table(shapes: list[Mapping[str, Any]]) -> np.ndarray:
    """Polygon vertices as one NaN-padded float64 array [K, Vmax, 2] (circles: all NaN)."""
    vmax = max((len(s["vertices"]) for s in shapes), default=0)
    table = np.full((len(shapes), vmax, 2), np.nan)
    for k, s in enumerate(shapes):
        if s["vertices"]:
            table[k, : len(s["vertices"])] = np.asarray(s["vertices"], dtype=np.float64)
    return table


def trajectory_arrays(result: Mapping[str, Any], params: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """The arrays of ``trajectory.npz`` (table in the module docstring) for one episode result
    of :func:`wolfpack.run_episodes` run with ``record=True``; ``params`` are the resolved
    parameters of the run (for ``border``, ``ts``, ``capture_distance``)."""
    traj = result.get("trajectory")
    if traj is None:
        raise ValueError("episode result has no trajectory (run with record=True)")
    shapes = list(traj["obstacle_shapes"])
    capture_step = result["capture_step"]
    cornered_step = result.get("cornered_step")
    ends = result.get("target_capture_steps") or [None] * int(result["targets"])
    return {
        "wolves": np.asarray(traj["wolves"], dtype=np.float64),
        "targets": np.asarray(traj["targets"], dtype=np.float64),
        "energy": np.asarray(traj["energy"], dtype=np.float64),
        "interaction": np.asarray(traj["interaction"], dtype=np.uint8),
        "outcome": np.array(str(result["outcome"])),
        "capture_step": np.array(-1 if capture_step is None else int(capture_step), dtype=np.int64),
        "target_capture_step": np.array([-1 if c is None else int(c) for c in ends], dtype=np.int64),
        "cornered_step": np.array(-1 if cornered_step is None else int(cornered_step), dtype=np.int64),
        "seed": np.array(int(result["seed"]), dtype=np.uint64),
        "obstacle_poses": np.asarray(traj["obstacle_poses"], dtype=np.float64),
        "obstacle_kind": np.array([str(s["kind"]) for s in shapes], dtype=str),
        "obstacle_radius": np.array([float(s["radius"]) for s in shapes], dtype=np.float64),
        "obstacle_vertices": _vertices_table(shapes),
        "border": np.asarray(params["world"]["border"], dtype=np.float64),
        "ts": np.array(float(params["world"]["ts"])),
        "capture_distance": np.array(float(params["capture"]["distance"])),
    }


def write_trajectory(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """Writes ``trajectory.npz`` (compressed: the interaction matrices are mostly zeros) under a
    temporary name first, then renames it: an interrupted write never leaves a file that looks
    like a trajectory."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)
    os.replace(tmp, path)


def load_trajectory(path: Path) -> dict[str, np.ndarray]:
    """Reads a ``trajectory.npz`` back into a dict of arrays (no pickles involved)."""
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def episode_detail(result: Mapping[str, Any]) -> dict[str, Any]:
    """One entry of ``summary.json``'s ``episodes_detail``: seed, outcome, steps, capture_step
    (``null`` if none), cornered_step (first step a target was cornered, ``null`` if never),
    energy [N+M] (J, wolves first) and collisions [N+M] (steps spent overlapping an obstacle
    or, for wolves, another wolf)."""
    cs = result["capture_step"]
    cornered = result.get("cornered_step")
    return {
        "seed": int(result["seed"]),
        "outcome": str(result["outcome"]),
        "steps": int(result["steps"]),
        "capture_step": None if cs is None else int(cs),
        "cornered_step": None if cornered is None else int(cornered),
        "energy": [float(e) for e in np.asarray(result["energy"]).ravel()],
        "collisions": [int(c) for c in np.asarray(result["collisions"]).ravel()],
    }


def write_json_atomic(path: Path, data: Mapping[str, Any]) -> None:
    """Writes JSON to a temporary name in the same folder, then renames it into place, so a
    reader (or a crashed run) never sees a half-written file under the final name."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=2, allow_nan=False)
        f.write("\n")
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
