"""Episodes packed for the page: integers on fixed grids, differenced over time, written as
zigzag varints and base64.

Precision (what the page shows against what the simulator computed):

=========================  ===========  ====================================================
quantity                   grid         largest error after decoding
=========================  ===========  ====================================================
positions x, y (m)         1 mm         0.5 mm
headings θ (rad)           0.001 rad    0.0005 rad
speeds v (m/s)             1 mm/s       0.5 mm/s
turn rates ω (rad/s)       0.001 rad/s  0.0005 rad/s
obstacle centres, angles   1 mm, 0.001  0.5 mm, 0.0005 rad
energy (J)                 1 mJ         0.5 mJ
obstacle shapes (m)        0.1 mm       0.05 mm (written as decimals, not differenced)
interaction links          exact        one bit per observer-observed pair and step
law modes                  exact        run lengths of each agent's mode code
=========================  ===========  ====================================================

The differences are taken between integers, so decoding adds them back exactly: the error
never grows along an episode. A 300-step episode of the documented scenario (6 agents, 12
obstacles) takes about 50 KB of text.

Stream layout: an array ``[rows, S]`` (S series, e.g. every agent's x, y, θ, v, ω) is rounded
to its grid, differenced along the rows (the first row kept as it is), read series by series
(``[S, rows]``, so that one series' small steps sit together) and each integer written as a
zigzag LEB128 varint: 0, -1, 1, -2, … become 0, 1, 2, 3, …, seven bits a byte, the high bit
set on every byte but a number's last. ``page.js`` reads it back the same way.

The law modes (``wolf_mode``, ``target_mode`` of ``trajectory.npz``) change seldom, so they are
run lengths instead: agent by agent, (code, run length) pairs as the same varints, the runs of
one agent covering its rows. Their codes index the page's ``mode_names``
(``wolfpack._core.LAW_MODES``); a file recorded with other names is mapped onto those by name.
"""

from __future__ import annotations

import base64
from typing import Any, Mapping

import numpy as np

from wolfpack import _core
from wolfpack.sides import SIDES

#: The law modes' names, indexed by the codes the page holds.
MODE_NAMES: tuple[str, ...] = tuple(_core.LAW_MODES)
#: Grid of positions (m) and of speeds (m/s).
POSITION_STEP = 1e-3
#: Grid of angles (rad) and of turn rates (rad/s).
ANGLE_STEP = 1e-3
#: Grid of accumulated energy (J).
ENERGY_STEP = 1e-3
#: Decimals of obstacle shapes (local polygon vertices, radii), which do not change over time.
SHAPE_DECIMALS = 4
#: The grid of each of an agent's five recorded channels x, y, θ, v, ω.
AGENT_STEPS = (POSITION_STEP, POSITION_STEP, ANGLE_STEP, POSITION_STEP, ANGLE_STEP)
#: The grid of an obstacle pose's x, y, angle.
POSE_STEPS = (POSITION_STEP, POSITION_STEP, ANGLE_STEP)
#: Magnitudes past this many grid steps are refused (a value that large is no world's: 2**40 mm
#: is a million km), so that every varint fits the page's 53-bit integers with room to spare.
MAX_UNITS = 2**40


def _varints(values: np.ndarray) -> bytes:
    """Zigzag LEB128 varints of int64 ``values`` (1-D), vectorised: each value's seven-bit
    groups side by side, the continuation bit on all but its last, then the used groups in
    order."""
    v = np.asarray(values, dtype=np.int64).ravel()
    if v.size == 0:
        return b""
    z = ((v << 1) ^ (v >> 63)).astype(np.uint64)
    groups = 7  # 49 bits: enough for MAX_UNITS after zigzag
    shifts = np.arange(groups, dtype=np.uint64) * np.uint64(7)
    parts = ((z[:, None] >> shifts[None, :]) & np.uint64(0x7F)).astype(np.uint8)
    # A number takes one byte, plus one for each seven-bit group above its lowest that is not 0.
    length = 1 + ((z[:, None] >> shifts[None, 1:]) > 0).sum(axis=1)
    used = np.arange(groups)[None, :] < length[:, None]
    more = np.arange(groups)[None, :] < (length - 1)[:, None]
    parts = parts | (more.astype(np.uint8) << 7)
    return parts[used].tobytes()


def _read_varints(data: bytes, count: int) -> np.ndarray:
    """The inverse of :func:`_varints` (for tests and :func:`decode_episode`)."""
    out = np.empty(count, dtype=np.int64)
    pos = 0
    for i in range(count):
        value = shift = 0
        while True:
            byte = data[pos]
            pos += 1
            value |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                break
        out[i] = (value >> 1) ^ -(value & 1)
    if pos != len(data):
        raise ValueError(f"{len(data) - pos} bytes left after {count} numbers")
    return out


def pack_series(values: np.ndarray, steps: tuple[float, ...] | float) -> str:
    """``values`` [rows, ..., C] (C channels, each on its grid ``steps[c]``, or one grid for
    all) as base64 text: quantised, differenced over rows, series by series."""
    a = np.asarray(values, dtype=np.float64)
    rows = a.shape[0]
    flat = a.reshape(rows, -1, a.shape[-1]) if a.ndim > 1 else a.reshape(rows, 1, 1)
    grid = np.broadcast_to(np.asarray(steps, dtype=np.float64), flat.shape[-1:])
    q = np.rint(flat / grid).reshape(rows, -1)
    if q.size and not np.all(np.abs(q) < MAX_UNITS):
        raise ValueError(f"values too large to encode (|value| >= {MAX_UNITS} grid steps)")
    q = q.astype(np.int64)
    d = np.diff(q, axis=0, prepend=np.zeros((1, q.shape[1]), dtype=np.int64))
    return base64.b64encode(_varints(d.T.ravel())).decode("ascii")


def unpack_series(text: str, rows: int, shape: tuple[int, ...], steps: tuple[float, ...] | float) -> np.ndarray:
    """The inverse of :func:`pack_series`: float64 ``[rows, *shape]``."""
    width = int(np.prod(shape))
    d = _read_varints(base64.b64decode(text), rows * width).reshape(width, rows).T
    q = np.cumsum(d, axis=0)
    per = np.rint(1.0 / np.broadcast_to(np.asarray(steps, dtype=np.float64), shape[-1:]))
    return q.reshape(rows, *shape) / per  # 3413 / 1000 is 3.413, as the page reads it


def pack_bits(flags: np.ndarray) -> str:
    """0/1 flags (any shape, read in C order) as base64 of their bits, most significant first."""
    return base64.b64encode(np.packbits(np.asarray(flags, dtype=np.uint8).ravel()).tobytes()).decode("ascii")


def unpack_bits(text: str, shape: tuple[int, ...]) -> np.ndarray:
    count = int(np.prod(shape))
    return np.unpackbits(np.frombuffer(base64.b64decode(text), dtype=np.uint8), count=count).reshape(shape)


def pack_runs(codes: np.ndarray) -> str:
    """Non-negative integer ``codes`` [rows, S] as base64 text: series by series, (code, run
    length) pairs as varints."""
    c = np.asarray(codes, dtype=np.int64)
    c = c.reshape(c.shape[0], -1).T  # [S, rows]
    pairs = []
    for series in c:
        if not series.size:
            continue
        starts = np.flatnonzero(np.concatenate([[True], series[1:] != series[:-1]]))
        lengths = np.diff(np.append(starts, series.size))
        pairs.append(np.stack([series[starts], lengths], axis=1).ravel())
    return base64.b64encode(_varints(np.concatenate(pairs) if pairs else np.zeros(0, np.int64))).decode("ascii")


def unpack_runs(text: str, rows: int, width: int) -> np.ndarray:
    """The inverse of :func:`pack_runs`: int64 ``[rows, width]``."""
    data = base64.b64decode(text)
    out = np.empty((width, rows), dtype=np.int64)
    values, pos = _read_all_varints(data), 0
    for s in range(width):
        t = 0
        while t < rows:
            code, length = values[pos], values[pos + 1]
            pos += 2
            if length < 1 or t + length > rows:
                raise ValueError(f"series {s}: a run of {length} at row {t} of {rows}")
            out[s, t : t + length] = code
            t += length
    if pos != len(values):
        raise ValueError(f"{len(values) - pos} numbers left after {width} series")
    return out.T


def _read_all_varints(data: bytes) -> np.ndarray:
    """Every zigzag varint of ``data``."""
    ends = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) < 0x80)
    return _read_varints(data, len(ends))


def page_modes(arrays: Mapping[str, np.ndarray]) -> np.ndarray | None:
    """The episode's law modes [T+1, N+M] (wolves first) as codes of :data:`MODE_NAMES`, or
    None where the file records none (older files). A file written with other names is mapped
    onto these by name; a name they lack becomes 0, none."""
    if "wolf_mode" not in arrays or "target_mode" not in arrays:
        return None
    codes = np.concatenate([np.asarray(arrays["wolf_mode"]), np.asarray(arrays["target_mode"])], axis=1).astype(np.int64)
    names = tuple(str(n) for n in np.asarray(arrays["mode_names"]).reshape(-1)) if "mode_names" in arrays else MODE_NAMES
    if names != MODE_NAMES:
        lookup = np.array([MODE_NAMES.index(n) if n in MODE_NAMES else 0 for n in names] or [0], dtype=np.int64)
        codes = lookup[np.clip(codes, 0, len(lookup) - 1)]
    return codes


def first_sighting(arrays: Mapping[str, np.ndarray]) -> int:
    """The first step at which a wolf sensed a target (the interaction matrix: row = observer),
    or -1 when none ever did."""
    n = arrays["wolves"].shape[1]
    links = np.asarray(arrays["interaction"])[:, :n, n:]
    seen = np.flatnonzero(links.reshape(links.shape[0], -1).any(axis=1))
    return int(seen[0]) + 1 if seen.size else -1


def _int(arrays: Mapping[str, np.ndarray], key: str, default: int = -1) -> int:
    return int(np.asarray(arrays[key])) if key in arrays else default


def encode_episode(arrays: Mapping[str, np.ndarray], params: Mapping[str, Any], label: str = "", drivers: Mapping[str, str] | None = None) -> dict[str, Any]:
    """One episode of ``trajectory.npz`` (checked by :func:`wolfpack.logs.check_trajectory`) as
    the page's JSON object; ``params`` give the body size, sensing radii and laws (the arrays
    carry the border, Ts and capture distance); ``drivers`` name who drove each side where
    that was not the law of ``params`` (a model)."""
    laws = {side: str(params["policies"][side]) for side in SIDES} | dict(drivers or {})
    wolves, targets = np.asarray(arrays["wolves"], dtype=np.float64), np.asarray(arrays["targets"], dtype=np.float64)
    rows, n, m = wolves.shape[0], wolves.shape[1], targets.shape[1]
    agents = np.concatenate([wolves, targets], axis=1)
    poses = np.asarray(arrays["obstacle_poses"], dtype=np.float64)
    table = np.asarray(arrays["obstacle_vertices"], dtype=np.float64)
    kinds = [str(k) for k in np.asarray(arrays["obstacle_kind"]).reshape(-1)]
    local = [np.round(table[k][~np.isnan(table[k]).any(axis=1)], SHAPE_DECIMALS).tolist() if table.size else [] for k in range(len(kinds))]
    outcome = str(np.asarray(arrays["outcome"]))
    collisions = [int(c) for c in np.asarray(arrays.get("collisions", np.zeros(n + m))).reshape(-1)]
    ends = [int(c) for c in np.asarray(arrays["target_capture_step"]).reshape(-1)] if "target_capture_step" in arrays else [rows - 1 if outcome in ("captured", "cornered") else -1] * m
    agent_params = params["agents"]
    episode = {
        "label": label,
        "seed": _int(arrays, "seed"),
        "outcome": outcome,
        "steps": rows - 1,
        "wolves": n,
        "targets": m,
        "border": [float(v) for v in np.asarray(arrays["border"])],
        "ts": float(np.asarray(arrays["ts"])),
        "capture_distance": float(np.asarray(arrays["capture_distance"])),
        "sense_radius": [float(agent_params["wolf"]["sense_radius"]), float(agent_params["target"]["sense_radius"])],
        "body": [float(agent_params["body"]["height"]), float(agent_params["body"]["base"])],
        # The page casts each agent's lidar from its state as the core does (without the
        # learners' noise): ray k at heading + 2πk/rays, to the first obstacle or wall, at most range.
        "lidar": [int(params["env"]["lidar"]["rays"]), float(params["env"]["lidar"]["range"])],
        # Where the hunting points mean something (the bvc law aims at them, the capture rule
        # hunting_points asks for them), their ring's radius: the page places them from the state.
        "hunting_radius": float(params["bvc"]["radius"]) if laws["wolves"] == "bvc" or params["capture"]["rule"] == "hunting_points" else None,
        "wolf_law": laws["wolves"],
        "target_law": laws["targets"],
        "capture_step": _int(arrays, "capture_step"),
        "target_capture_step": ends,
        "cornered_step": _int(arrays, "cornered_step"),
        "first_sighting": first_sighting(arrays),
        # An episode ends at its collision, so a wolf with steps in contact collided there;
        # for targets (whose contacts do not end it) only the count is recorded.
        "collision_step": rows - 1 if outcome == "collision" else -1,
        "collisions": collisions,
        "obstacle_kind": kinds,
        "obstacle_radius": [round(float(r), SHAPE_DECIMALS) for r in np.asarray(arrays["obstacle_radius"]).reshape(-1)],
        "obstacle_local": local,
        "agents": pack_series(agents, AGENT_STEPS),
        "poses": pack_series(poses, POSE_STEPS) if poses.shape[1] else "",
        "energy": pack_series(np.asarray(arrays["energy"], dtype=np.float64)[..., None], ENERGY_STEP),
        "interaction": pack_bits(arrays["interaction"]),
    }
    modes = page_modes(arrays)
    if modes is not None:  # older files record none: the page then shows none
        episode["modes"] = pack_runs(modes)
    return episode


def decode_episode(episode: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """What the page reads back from :func:`encode_episode`'s object: ``wolves`` [T+1, N, 5],
    ``targets`` [T+1, M, 5], ``obstacle_poses`` [T+1, K, 3], ``energy`` [T+1, N+M],
    ``interaction`` [T, N+M, N+M], and where the episode has them ``modes`` [T+1, N+M] (codes
    of :data:`MODE_NAMES`, wolves first) (the Python twin of ``page.js``'s decoder)."""
    rows, n, m, k = episode["steps"] + 1, episode["wolves"], episode["targets"], len(episode["obstacle_kind"])
    agents = unpack_series(episode["agents"], rows, (n + m, 5), AGENT_STEPS)
    out = {
        "wolves": agents[:, :n],
        "targets": agents[:, n:],
        "obstacle_poses": unpack_series(episode["poses"], rows, (k, 3), POSE_STEPS) if k else np.zeros((rows, 0, 3)),
        "energy": unpack_series(episode["energy"], rows, (n + m, 1), ENERGY_STEP)[..., 0],
        "interaction": unpack_bits(episode["interaction"], (rows - 1, n + m, n + m)),
    }
    if episode.get("modes") is not None:
        out["modes"] = unpack_runs(episode["modes"], rows, n + m)
    return out
