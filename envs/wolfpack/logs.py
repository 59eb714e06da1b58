"""Output files of ``wolfpack hunt --out DIR``: the logs of docs/world-and-laws.md §1.7, in the formats of
docs/interface.md#wolfpack-hunt and docs/interface.md#trajectorynpz.

Layout of ``DIR``::

    DIR/summary.json                       written last (temp name, then rename)
    DIR/INCOMPLETE                         only while the run is going, or after it was
                                           interrupted (then there is no summary.json)
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
``wolf_mode``          uint8 [T+1, N]       the mode each wolf's law was in at the step that
                                            led to row t's state (codes into ``mode_names``;
                                            row 0, before any step, is 0 = ``none``, as is a
                                            step driven by a model); older files lack it
``target_mode``        uint8 [T+1, M]       as ``wolf_mode``, for the targets' law
``mode_names``         str [C]              the name of every mode code, 0 first
                                            (``wolfpack._core.LAW_MODES``; world-and-laws
                                            §1.8 says what each means)
``collisions``         uint32 [N+M]         steps each agent spent touching an obstacle (or, a
                                            wolf, another wolf); the plots mark a collision
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
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator, Mapping

import numpy as np

from wolfpack import _core

SUMMARY_NAME = "summary.json"
#: The marker of a run in progress or interrupted: written first, removed once summary.json is.
INCOMPLETE_NAME = "INCOMPLETE"


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
    return mode_arrays(traj) | {
        "wolves": np.asarray(traj["wolves"], dtype=np.float64),
        "targets": np.asarray(traj["targets"], dtype=np.float64),
        "energy": np.asarray(traj["energy"], dtype=np.float64),
        "interaction": np.asarray(traj["interaction"], dtype=np.uint8),
        "collisions": np.asarray(result["collisions"], dtype=np.uint32),
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


def mode_arrays(traj: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """``wolf_mode``, ``target_mode`` and ``mode_names`` of ``trajectory.npz`` from a dict
    holding the first two (a recorded trajectory, or states stacked by
    :mod:`wolfpack.viewer.play`); nothing when it holds no modes."""
    if "wolf_mode" not in traj or "target_mode" not in traj:
        return {}
    return {
        "wolf_mode": np.asarray(traj["wolf_mode"], dtype=np.uint8),
        "target_mode": np.asarray(traj["target_mode"], dtype=np.uint8),
        "mode_names": np.array(_core.LAW_MODES, dtype=str),
    }


@contextmanager
def atomic_path(path: Path, keep_suffix: bool = False) -> Iterator[Path]:
    """Yields a temporary name beside ``path`` to write to; renames it to ``path`` when the
    block ends normally and removes it whatever else happens (an error, a KeyboardInterrupt
    landing inside the writer), so ``path`` only ever names a complete file. The name is
    ``.NAME.tmp``, or with ``keep_suffix`` ``.STEM.tmp.SUFFIX`` (for writers that choose the
    format by extension: matplotlib, ffmpeg)."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}" if keep_suffix else f".{path.name}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_trajectory(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """Writes ``trajectory.npz`` (compressed: the interaction matrices are mostly zeros) under a
    temporary name first, then renames it: an interrupted write never leaves a file that looks
    like a trajectory, nor the temporary file."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)


def load_trajectory(path: Path) -> dict[str, np.ndarray]:
    """Reads a ``trajectory.npz`` back into a dict of arrays (no pickles involved)."""
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


#: The arrays ``wolfpack replay`` needs (older files may lack target_capture_step and
#: cornered_step; seed is not drawn).
REQUIRED_KEYS = ("wolves", "targets", "energy", "interaction", "outcome", "capture_step", "obstacle_poses", "obstacle_kind", "obstacle_radius", "obstacle_vertices", "border", "ts", "capture_distance")
OBSTACLE_KINDS = ("static_circle", "moving_circle", "static_polygon", "moving_polygon")


def check_trajectory(arrays: Mapping[str, np.ndarray]) -> None:
    """Checks a ``trajectory.npz`` read back (:func:`load_trajectory`) against the table in this
    module's docstring before anything draws it: the keys, numeric dtypes (no strings or
    objects where numbers belong), shapes consistent with each other (T, N, M, K from
    ``wolves``, ``targets`` and ``obstacle_poses``), finite poses, energies, radii, border and
    capture distance, an interaction matrix of 0s and 1s, and law modes (where present) that
    name a mode. Raises ValueError naming the array and what is wrong."""
    missing = [k for k in REQUIRED_KEYS if k not in arrays]
    if missing:
        raise ValueError(f"not a wolfpack trajectory (missing {', '.join(missing)})")
    a = {k: np.asarray(v) for k, v in arrays.items()}
    numeric = [k for k in REQUIRED_KEYS + ("target_capture_step", "cornered_step", "seed") if k in a and k not in ("outcome", "obstacle_kind")]
    for k in numeric:
        if a[k].dtype.kind not in "biuf":
            raise ValueError(f"{k}: must hold numbers, got dtype {a[k].dtype}")
    for k in ("wolf_mode", "target_mode"):
        if k in a and a[k].dtype.kind not in "iu":
            raise ValueError(f"{k}: must hold integer codes, got dtype {a[k].dtype}")
    if "mode_names" in a and (a["mode_names"].dtype.kind != "U" or a["mode_names"].ndim != 1):
        raise ValueError(f"mode_names: must be a list of strings, got dtype {a['mode_names'].dtype} and shape {a['mode_names'].shape}")
    for k in ("outcome", "obstacle_kind"):
        if a[k].dtype.kind != "U":
            raise ValueError(f"{k}: must hold strings, got dtype {a[k].dtype}")

    def shape(k: str, want: tuple, meaning: str) -> None:
        if a[k].shape != want:
            raise ValueError(f"{k}: expected shape {meaning} = {want}, got {a[k].shape}")

    w, t, poses = a["wolves"], a["targets"], a["obstacle_poses"]
    if w.ndim != 3 or w.shape[0] < 1 or w.shape[1] < 1 or w.shape[2] != 5:
        raise ValueError(f"wolves: expected shape [T+1, N, 5] with T+1 >= 1 and N >= 1, got {w.shape}")
    rows, n = w.shape[0], w.shape[1]
    if t.ndim != 3 or t.shape[0] != rows or t.shape[1] < 1 or t.shape[2] != 5:
        raise ValueError(f"targets: expected shape [T+1, M, 5] = [{rows}, M >= 1, 5] (T+1 from wolves), got {t.shape}")
    m = t.shape[1]
    if poses.ndim != 3 or poses.shape[0] != rows or poses.shape[2] != 3:
        raise ValueError(f"obstacle_poses: expected shape [T+1, K, 3] = [{rows}, K, 3] (T+1 from wolves), got {poses.shape}")
    k = poses.shape[1]
    shape("energy", (rows, n + m), "[T+1, N+M]")
    shape("interaction", (rows - 1, n + m, n + m), "[T, N+M, N+M]")
    shape("obstacle_kind", (k,), "[K]")
    shape("obstacle_radius", (k,), "[K]")
    verts = a["obstacle_vertices"]
    if verts.ndim != 3 or verts.shape[0] != k or verts.shape[2] != 2:
        raise ValueError(f"obstacle_vertices: expected shape [K, V, 2] = [{k}, V, 2] (K from obstacle_poses), got {verts.shape}")
    for key in ("outcome", "capture_step", "ts", "capture_distance", "cornered_step", "seed"):
        if key in a and a[key].shape != ():
            raise ValueError(f"{key}: expected a scalar, got shape {a[key].shape}")
    if "target_capture_step" in a:
        shape("target_capture_step", (m,), "[M]")
    names = len(a["mode_names"]) if "mode_names" in a else len(_core.LAW_MODES)
    for key, width, meaning in (("wolf_mode", n, "[T+1, N]"), ("target_mode", m, "[T+1, M]")):
        if key in a:
            shape(key, (rows, width), meaning)
            if a[key].size and not (0 <= int(a[key].min()) and int(a[key].max()) < names):
                raise ValueError(f"{key}: codes must lie in [0, {names}) (mode_names), got {int(a[key].min())} to {int(a[key].max())}")
    shape("border", (4,), "[x_min, y_min, x_max, y_max]")
    for key in ("wolves", "targets", "energy", "obstacle_poses", "obstacle_radius", "border", "ts", "capture_distance"):
        bad = ~np.isfinite(a[key])
        if bad.any():
            where = np.argwhere(bad)[0].tolist() if a[key].ndim else []
            raise ValueError(f"{key}: not finite{f' at index {where}' if where else ''} ({a[key][tuple(where)] if where else a[key]})")
    if np.isinf(verts).any():
        raise ValueError("obstacle_vertices: infinite entries (only NaN padding is allowed)")
    flags = a["interaction"]
    if flags.size and not np.isin(flags, (0, 1)).all():
        where = np.argwhere(~np.isin(flags, (0, 1)))[0].tolist()
        raise ValueError(f"interaction: entries are 0 or 1, got {flags[tuple(where)]} at index {where}")
    x0, y0, x1, y1 = a["border"].tolist()
    if not (x0 < x1 and y0 < y1):
        raise ValueError(f"border: expected x_min < x_max and y_min < y_max, got {a['border'].tolist()}")
    if not float(a["ts"]) > 0 or not float(a["capture_distance"]) > 0:
        raise ValueError(f"ts and capture_distance: must be > 0, got {float(a['ts'])} and {float(a['capture_distance'])}")
    if (a["obstacle_radius"] < 0).any():
        raise ValueError(f"obstacle_radius: must be >= 0, got {a['obstacle_radius'].tolist()}")
    for i, kind in enumerate(a["obstacle_kind"].tolist()):
        if kind not in OBSTACLE_KINDS:
            raise ValueError(f"obstacle_kind[{i}]: expected one of {', '.join(OBSTACLE_KINDS)}, got {kind!r}")
        if kind.endswith("polygon") and int((~np.isnan(verts[i]).any(axis=1)).sum()) < 3:
            raise ValueError(f"obstacle_vertices[{i}]: a polygon needs at least 3 vertices")


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
    reader (or a crashed run) never sees a half-written file under the final name; the
    temporary file is removed whatever happens."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(data, f, indent=2, allow_nan=False)
            f.write("\n")
            f.flush()
            os.fsync(f.fileno())
