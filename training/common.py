"""What the training scripts share: argument checks, seeds, hyperparameters, run folders,
policy rollouts on the native batch, and the evaluation engine behind ``evaluate.py``.

Seeds (disjoint by construction, so "held-out" means held out):

========================  ==========================================================
what                      world seeds
========================  ==========================================================
``evaluate.py --seed S``  ``S, S+1, ...`` — the same episodes as ``wolfpack hunt --seed S``
training (``--seed s``)   ``TRAIN_SEED_BASE·(s+1) + e`` for world e (episodes go on in
                          that world's own random streams)
imitation (``--seed s``)  ``IMITATION_SEED_BASE·(s+1) + e``
evaluation callback       ``HELD_OUT_SEED + k`` for episode k
========================  ==========================================================
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import wolfpack
import yaml
from wolfpack import _core
from wolfpack.batch import OUTCOMES, BatchEnv, first_cornered_step, resolve_params
from wolfpack.config import parse_override
from wolfpack.evaluation import HELD_OUT_SEED, IMITATION_SEED_BASE, TRAIN_SEED_BASE, Policy, report, rollout, wilson_interval  # noqa: F401  (re-exported for the scripts)
from wolfpack.learn.run import keep_freed_memory, prefer_passive_omp
from wolfpack.models import CONFIG_FILE, MODEL_FILE, SavedPolicy, find_model, load_policy, native_model_folders, run_label  # noqa: F401 (MODEL_FILE: the scripts take it from here)
from wolfpack.sides import SCRIPTED_LAWS, mode_key, side_action_mode, side_observation

# The scripts run torch beside the batch's threads: its OpenMP workers should sleep while they
# wait, not spin (the reason and the measurements: wolfpack.learn.run.prefer_passive_omp). This
# module is imported before torch by every script; a user's own OMP_WAIT_POLICY wins. Freed
# tensors stay in the heap for the next minibatch, as in `wolfpack train` (the reason:
# wolfpack.learn.run.keep_freed_memory), so that both trainers are measured alike.
prefer_passive_omp()
keep_freed_memory()

SIDES = ("wolves", "targets")
WOLF_LAWS = SCRIPTED_LAWS["wolves"]
TARGET_LAWS = SCRIPTED_LAWS["targets"]
HYPERPARAMS_PATH = Path(__file__).with_name("hyperparams.yaml")


class UsageError(ValueError):
    """Bad arguments: the scripts print it on one line and exit with status 2."""


def algorithms() -> dict[str, type]:
    from stable_baselines3 import PPO, SAC

    return {"ppo": PPO, "sac": SAC}


def check_side(side: str) -> str:
    if side not in SIDES:
        raise UsageError(f"--side must be 'wolves' or 'targets', got {side!r}")
    return side


def check_algo(algo: str) -> str:
    if algo not in ("ppo", "sac"):
        raise UsageError(f"--algo must be 'ppo' or 'sac', got {algo!r}")
    return algo


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1 (argparse prints the message and exits with 2)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def seed_int(text: str) -> int:
    """argparse type: an integer seed >= 0."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a seed (integer >= 0), got {text!r}")
    return value


def env_params(params_path: str | None, sets: Sequence[str], side: str | None = None) -> dict:
    """The validated params of a run: ``--params`` (default: the documented scenario) with the
    ``--set k=v`` overrides. The learning side's law entry stays as it is (the core ignores it
    for learners), the opponent's law is the one the model is trained and evaluated against."""
    overrides = dict(parse_override(s) for s in sets)
    return resolve_params(params_path, overrides)


def hyperparams(algo: str, finetune: bool, sets: Sequence[str]) -> dict:
    """SB3 keyword arguments for ``algo``: ``hyperparams.yaml``'s ``<algo>`` section, then
    its ``finetune.<algo>`` section when starting from another model, then ``--hp k=v``."""
    table = yaml.safe_load(HYPERPARAMS_PATH.read_text())
    hp = dict(table[algo])
    if finetune:
        hp.update(table.get("finetune", {}).get(algo, {}))
    for s in sets:
        key, value = parse_override(s)
        node = hp
        parts = key.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value
    return hp


def sb3_kwargs(hp: dict) -> dict:
    """``hp`` (plain YAML data) made ready for an SB3 constructor: ``policy_kwargs.activation_fn``
    names (``tanh``, ``relu``) become torch modules."""
    import torch

    kw = json.loads(json.dumps(hp))
    pk = kw.get("policy_kwargs", {})
    if "activation_fn" in pk:
        activations = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}
        if pk["activation_fn"] not in activations:
            raise UsageError(f"policy_kwargs.activation_fn must be 'tanh' or 'relu', got {pk['activation_fn']!r}")
        pk["activation_fn"] = activations[pk["activation_fn"]]
    return kw


def versions() -> dict:
    import stable_baselines3
    import torch

    return {
        "wolfpack": wolfpack.__version__,
        "stable_baselines3": stable_baselines3.__version__,
        "torch": str(torch.__version__),
        "numpy": np.__version__,
        "python": sys.version.split()[0],
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
    }


def write_config(out: Path, config: dict) -> None:
    (out / CONFIG_FILE).write_text(yaml.safe_dump(json.loads(json.dumps(config)), sort_keys=False))


def prepare_out(out: str | Path) -> Path:
    """``--out`` as a directory that exists and is writable (created if missing)."""
    path = Path(out)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write_test"
        probe.write_text("")
        probe.unlink()
    except OSError as e:
        raise UsageError(f"--out {out}: cannot write there ({e.strerror or e})") from None
    return path


@dataclass
class TrainedModel:
    """A saved model with the run configuration it came from."""

    path: Path
    side: str
    algo: str
    params: dict
    config: dict
    model: Any

    @property
    def label(self) -> str:
        """``<kind>:<run folder>``: kind ``imitation`` for imitate.py's models, else the algorithm
        (``ppo:wolves_ft``, ``mappo:wolves``); checkpoints add their file name (SB3) or agent
        steps (``wolfpack train``)."""
        return self.model.name if isinstance(self.model, SavedPolicy) else run_label(self.path, self.config)

    @property
    def action_mode(self) -> str:
        """The mode its actions are in: its side's own ``env.*_action_mode`` in its params, else
        ``env.action_mode``."""
        return side_action_mode(self.params, self.side)

    def act(self, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
        """Actions for a batch of observations [..., D] → [..., 2] (float32)."""
        flat = obs.reshape(-1, obs.shape[-1])
        actions, _ = self.model.predict(flat, deterministic=deterministic)
        return np.asarray(actions, dtype=np.float32).reshape(*obs.shape[:-1], 2)


def load_model(where: str | Path, device: str = "cpu", side: str | None = None) -> TrainedModel:
    """A model from a run folder of ``wolfpack train`` (``side`` picks one side of a run in which
    both learned) or one side's model folder in it, or an SB3 run folder (``DIR/model.zip`` +
    ``DIR/config.yaml``) or a ``.zip`` next to its run's ``config.yaml`` (checkpoints: the run
    folder is the zip's parent or grandparent)."""
    if native_model_folders(where):
        try:
            policy = load_policy(where, side)
        except ValueError as e:
            raise UsageError(str(e)) from None
        expected = observation_size(_core.validate_params(policy.params), policy.side)
        if policy.obs_dim != expected:
            raise UsageError(f"model {where}: it takes {policy.obs_dim} observations, but this version of wolfpack gives the {policy.side} {expected} on its params (retrain it)")
        return TrainedModel(policy.path, policy.side, policy.algo, _core.validate_params(policy.params), policy.config, policy)
    try:
        zip_path, config_path = find_model(where)
    except FileNotFoundError as e:
        raise UsageError(f"model {where}: no such model file ({e})") from None
    if config_path is None:
        raise UsageError(f"model {where}: no {CONFIG_FILE} beside it or in its parent folder (which params was it trained on?)")
    config = yaml.safe_load(config_path.read_text())
    side, algo = config.get("side"), config.get("algo")
    if side not in SIDES or algo not in ("ppo", "sac"):
        raise UsageError(f"{config_path}: side/algo missing or invalid ({side!r}, {algo!r})")
    try:
        model = algorithms()[algo].load(zip_path, device=device)
    except Exception as e:  # a truncated or foreign zip: say which file
        raise UsageError(f"model {zip_path}: cannot load it as an SB3 {algo.upper()} model ({type(e).__name__}: {e})") from None
    params = _core.validate_params(config["params"])
    expected = observation_size(params, side)
    got = int(model.observation_space.shape[0])
    if got != expected:
        raise UsageError(f"model {zip_path}: it takes {got} observations, but this version of wolfpack gives the {side} {expected} on its params (trained on an older observation layout? retrain it)")
    return TrainedModel(zip_path, side, algo, params, config, model)


def observation_size(params: dict, side: str) -> int:
    """The observation length of ``side`` on ``params`` (the module docstring of
    :mod:`wolfpack.parallel_env` has the layout)."""
    batch = BatchEnv(params, num_envs=1, learners=side, seed=0, threads=1)
    return batch.wolf_obs_dim if side == "wolves" else batch.target_obs_dim


# --- rollouts and evaluation (the engine: wolfpack.evaluation) ------------------------------


def record_episode(params: dict, seed: int, *, wolves: Policy | None = None, targets: Policy | None = None) -> dict:
    """Episode ``seed`` (as in :func:`rollout`) step by step, as the trajectory arrays of
    ``wolfpack hunt --out`` (see :mod:`wolfpack.logs`) that :mod:`wolfpack.plots` draws."""
    learners = {(False, False): "none", (True, False): "wolves", (False, True): "targets", (True, True): "all"}[(wolves is not None, targets is not None)]
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
    for side, laws, into in (("wolves", WOLF_LAWS, wolves), ("targets", TARGET_LAWS, targets)):
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


#: A player of one side in an evaluation: a scripted law's name or a model.
Player = "str | TrainedModel"


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
                raise UsageError(f"{who.label} is a model of the {who.side}, not of the {side}")
            p["env"][mode_key(side)] = who.action_mode
            p["env"].update(side_observation(who.params, side))
    return _core.validate_params(p)


def play(base: dict, wolves, targets, *, episodes: int, seed: int, threads: int | None = 1, deterministic: bool = True, progress=None) -> list[dict]:
    """Episodes ``seed ..`` (as :func:`rollout`) of ``wolves`` against ``targets`` (each a law's
    name or a :class:`TrainedModel`) on ``base``'s scenario; a model whose observation size does
    not fit ``base`` is a UsageError naming both sizes."""
    params = pairing_params(base, wolves, targets)
    policies = {}
    for side, who in (("wolves", wolves), ("targets", targets)):
        if not isinstance(who, str):
            ours, theirs = observation_size(params, side), int(who.model.observation_space.shape[0])
            if ours != theirs:
                raise UsageError(f"{who.label} takes {theirs} observations, the {side} of this scenario have {ours}")
            policies[side] = lambda obs, m=who: m.act(obs, deterministic)
    return rollout(params, episodes=episodes, seed=seed, threads=threads, progress=progress, **policies)


class Stopwatch:
    """Accumulates the seconds spent inside ``with`` blocks."""

    def __init__(self) -> None:
        self.total = 0.0

    def __enter__(self):
        self._t0 = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        self.total += time.perf_counter() - self._t0
