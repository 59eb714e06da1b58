"""Episodes between two players, each a scripted law's name or a saved model
(:class:`wolfpack.learn.sb3.TrainedModel`): the engine of ``training/evaluate.py``'s tables
and cross-play matrix, ``training/seeds.py`` and ``training/selfplay.py``, on
:func:`wolfpack.evaluation.rollout`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from wolfpack import _core
from wolfpack.batch import OUTCOMES, BatchEnv, first_cornered_step
from wolfpack.evaluation import MATRIX_KEYS, Policy, report, rollout
from wolfpack.learn.sb3 import TrainedModel, load_model, observation_size
from wolfpack.models import expand_models
from wolfpack.sides import OTHER_SIDE, SCRIPTED_LAWS, mode_key, side_observation

#: A player of one side in an evaluation: a scripted law's name or a model.
Player = "str | TrainedModel"


def record_episode(params: dict, seed: int, *, wolves: Policy | None = None, targets: Policy | None = None) -> dict:
    """Episode ``seed`` (as in :func:`rollout`) step by step, as the trajectory arrays of
    ``wolfpack hunt --out`` (see :mod:`wolfpack.logs`) that :mod:`wolfpack.plots` draws."""
    learners = {(False, False): "none", (True, False): "wolves", (False, True): "targets", (True, True): "both"}[(wolves is not None, targets is not None)]
    batch = BatchEnv(params, num_envs=1, learners=learners, seed=seed, autoreset=False, threads=1)
    out = batch.reset(seed)
    states = [batch.world_state(0)]
    while True:
        wa = wolves(out["obs_wolves"]) if wolves is not None else None
        ta = targets(out["obs_targets"]) if targets is not None else None
        out = batch.step(wa, ta)
        states.append(batch.world_state(0))
        if out["outcome"][0] != 0:
            break
    first = states[0]["obstacles"]
    width = max([len(o["vertices"]) for o in first] + [1])
    local = np.full((len(first), width, 2), np.nan)
    for k, o in enumerate(first):
        if len(o["vertices"]):
            c, s_ = np.cos(o["angle"]), np.sin(o["angle"])
            local[k, : len(o["vertices"])] = (np.asarray(o["vertices"]) - o["center"]) @ np.array([[c, -s_], [s_, c]])
    caps = out["capture_step"][0]
    outcome = OUTCOMES[int(out["outcome"][0])]
    return {
        "wolves": np.array([st["wolves"] for st in states]),
        "targets": np.array([st["targets"] for st in states]),
        "energy": np.array([st["energy"] for st in states]),
        "interaction": np.array([st["interaction"] for st in states[1:]]),
        "obstacle_poses": np.array([[[*o["center"], o["angle"]] for o in st["obstacles"]] for st in states]).reshape(len(states), len(first), 3),
        "obstacle_kind": np.array([f"{'moving' if o['moving'] else 'static'}_{o['kind']}" for o in first]),
        "obstacle_radius": np.array([o["radius"] for o in first]),
        "obstacle_vertices": local,
        "border": np.array(params["world"]["border"], dtype=float),
        "outcome": outcome,
        "capture_step": int(caps.max()) if outcome == "captured" else -1,
        "target_capture_step": np.asarray(caps, dtype=np.int64),
        "cornered_step": np.int64(first_cornered_step(out["cornered_step"][0])),
        "seed": seed,
        "ts": params["world"]["ts"],
        "capture_distance": params["capture"]["distance"],
    }


def available_laws(base: dict) -> tuple[list[str], list[str], list[str]]:
    """(wolf laws, target laws, skipped with reasons) that the core accepts on ``base``."""
    wolves, targets, skipped = [], [], []
    for side, into in (("wolves", wolves), ("targets", targets)):
        laws = SCRIPTED_LAWS[side]
        for law in laws:
            p = json.loads(json.dumps(base))
            p["policies"][side] = law
            try:
                _core.validate_params(p)
                into.append(law)
            except ValueError as e:
                skipped.append(f"{side}={law}: {e}")
    return wolves, targets, skipped


def with_laws(params: dict, wolves: str | None = None, targets: str | None = None) -> dict:
    p = json.loads(json.dumps(params))
    if wolves is not None:
        p["policies"]["wolves"] = wolves
    if targets is not None:
        p["policies"]["targets"] = targets
    return _core.validate_params(p)


def model_policies(m: TrainedModel, deterministic: bool = True) -> dict[str, Policy]:
    """``{"wolves": act}`` or ``{"targets": act}``: the keyword arguments of :func:`rollout`."""
    return {m.side: lambda obs: m.act(obs, deterministic)}


def evaluate_model(m: TrainedModel, *, episodes: int, seed: int, threads: int | None = 1, deterministic: bool = True, progress=None) -> dict:
    """``m`` against the scripted opponent it was trained with, on episodes ``seed ..``."""
    act = lambda obs: m.act(obs, deterministic)  # noqa: E731
    if m.side == "wolves":
        results = rollout(m.params, episodes=episodes, seed=seed, wolves=act, threads=threads, progress=progress)
        return report(results, m.label, m.params["policies"]["targets"])
    results = rollout(m.params, episodes=episodes, seed=seed, targets=act, threads=threads, progress=progress)
    return report(results, m.params["policies"]["wolves"], m.label)


def player_name(who) -> str:
    return who if isinstance(who, str) else who.label


def pairing_params(base: dict, wolves, targets) -> dict:
    """``base`` with each side's driver: a law's name sets ``policies.<side>``, a model sets its
    side's action mode and observation keys to the model's own (so that models trained in
    different modes, or with the pack's last sighting, meet)."""
    p = json.loads(json.dumps(base))
    for side, who in (("wolves", wolves), ("targets", targets)):
        if isinstance(who, str):
            p["policies"][side] = who
        else:
            if who.side != side:
                raise ValueError(f"{who.label} is a model of the {who.side}, not of the {side}")
            p["env"][mode_key(side)] = who.action_mode
            p["env"].update(side_observation(who.params, side))
    return _core.validate_params(p)


def play(base: dict, wolves, targets, *, episodes: int, seed: int, threads: int | None = 1, deterministic: bool = True, progress=None) -> list[dict]:
    """Episodes ``seed ..`` (as :func:`rollout`) of ``wolves`` against ``targets`` (each a law's
    name or a :class:`TrainedModel`) on ``base``'s scenario; a model whose observation size does
    not fit ``base`` is a ValueError naming both sizes."""
    params = pairing_params(base, wolves, targets)
    policies = {}
    for side, who in (("wolves", wolves), ("targets", targets)):
        if not isinstance(who, str):
            ours, theirs = observation_size(params, side), int(who.model.observation_space.shape[0])
            if ours != theirs:
                raise ValueError(f"{who.label} takes {theirs} observations, the {side} of this scenario have {ours}")
            policies[side] = lambda obs, m=who: m.act(obs, deterministic)
    return rollout(params, episodes=episodes, seed=seed, threads=threads, progress=progress, **policies)


def opponents_of(side: str, specs: list[str]) -> list:
    """The --against policies of the other side: laws by name, models loaded, leagues expanded."""
    out = []
    for spec in specs:
        if not Path(spec).exists():
            if spec not in SCRIPTED_LAWS[OTHER_SIDE[side]]:
                raise ValueError(f"--against {spec}: not a law of the {OTHER_SIDE[side]} ({', '.join(SCRIPTED_LAWS[OTHER_SIDE[side]])}) nor a model or league folder")
            out.append(spec)
            continue
        for path in expand_models([spec]):
            m = load_model(path)
            if m.side == OTHER_SIDE[side]:
                out.append(m)
    return out


# --- the cross-play matrix (training/evaluate.py --matrix): one cell per process-pool job ---

_MATRIX_MODELS: dict = {}


def matrix_player(spec: str):
    """A law's name as it is, a model path loaded (once per process)."""
    if spec in SCRIPTED_LAWS["wolves"] + SCRIPTED_LAWS["targets"]:
        return spec
    if spec not in _MATRIX_MODELS:
        _MATRIX_MODELS[spec] = load_model(spec)
    return _MATRIX_MODELS[spec]


def matrix_worker_start() -> None:
    """A matrix worker's torch on one thread: the cells run one per core."""
    import torch

    torch.set_num_threads(1)


def matrix_cell(job: tuple) -> dict:
    """One cell: (base params, wolf spec, target spec, episodes, seed, deterministic) → its
    report row (process-pool worker)."""
    base, w, t, episodes, seed, deterministic = job
    wolves, targets = matrix_player(w), matrix_player(t)
    results = play(base, wolves, targets, episodes=episodes, seed=seed, threads=1, deterministic=deterministic)
    r = report(results, player_name(wolves), player_name(targets))
    row = {k: r[k] for k in MATRIX_KEYS}
    row["capture_steps"] = r["capture_steps"]
    return row
