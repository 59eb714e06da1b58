"""The Stable-Baselines3 training path's run folders and models (``training/train.py``,
``training/imitate.py``, ``training/selfplay.py``, ``training/evaluate.py``): its
hyperparameters, its run configuration, and one loader for every saved model those scripts
take: an SB3 run folder (``DIR/model.zip`` + ``DIR/config.yaml``, or a checkpoint's zip) or a
``wolfpack train`` run folder.

Importing it makes torch's OpenMP workers sleep while they wait instead of spinning, and keeps
freed tensors in the heap for the next minibatch, as ``wolfpack train`` does (the reasons and
the measurements: :func:`wolfpack.learn.run.prefer_passive_omp` and
:func:`wolfpack.learn.run.keep_freed_memory`), so that both trainers are measured alike; the
scripts import it before torch, and a user's own ``OMP_WAIT_POLICY`` wins.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import yaml

import wolfpack
from wolfpack import _core
from wolfpack.batch import BatchEnv, resolve_params
from wolfpack.config import parse_override
from wolfpack.learn.run import keep_freed_memory, prefer_passive_omp
from wolfpack.models import CONFIG_FILE, SavedPolicy, find_model, load_policy, native_model_folders, run_label
from wolfpack.sides import SIDES, side_action_mode

prefer_passive_omp()
keep_freed_memory()

#: The SB3 algorithms the scripts train.
SB3_ALGOS = ("ppo", "sac")


def algorithms() -> dict[str, type]:
    """Each of :data:`SB3_ALGOS` to its SB3 class (imported here: SB3 brings torch)."""
    from stable_baselines3 import PPO, SAC

    return dict(zip(SB3_ALGOS, (PPO, SAC)))


def env_params(params_path: str | None, sets: Sequence[str], side: str | None = None) -> dict:
    """The validated params of a run: ``--params`` (default: the documented scenario) with the
    ``--set k=v`` overrides. The learning side's law entry stays as it is (the core ignores it
    for learners), the opponent's law is the one the model is trained and evaluated against."""
    overrides = dict(parse_override(s) for s in sets)
    return resolve_params(params_path, overrides)


#: The SB3 path's hyperparameters (kept apart from the environment's ``params.yaml`` and the
#: native trainer's ``recipes.yaml``): a section per algorithm, ``finetune.<algo>`` on top when a
#: run starts from another model, ``num_envs.<side>``.
HYPERPARAMS_PATH = Path(__file__).with_name("sb3_hyperparams.yaml")


def hyperparams(algo: str, finetune: bool, sets: Sequence[str]) -> dict:
    """SB3 keyword arguments for ``algo``: the ``<algo>`` section of :data:`HYPERPARAMS_PATH`,
    then its ``finetune.<algo>`` section when starting from another model, then ``--hp k=v``."""
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
            raise ValueError(f"policy_kwargs.activation_fn must be 'tanh' or 'relu', got {pk['activation_fn']!r}")
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
        raise ValueError(f"--out {out}: cannot write there ({e.strerror or e})") from None
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
            raise ValueError(str(e)) from None
        expected = observation_size(_core.validate_params(policy.params), policy.side)
        if policy.obs_dim != expected:
            raise ValueError(f"model {where}: it takes {policy.obs_dim} observations, but this version of wolfpack gives the {policy.side} {expected} on its params (retrain it)")
        return TrainedModel(policy.path, policy.side, policy.algo, _core.validate_params(policy.params), policy.config, policy)
    try:
        zip_path, config_path = find_model(where)
    except FileNotFoundError as e:
        raise ValueError(f"model {where}: no such model file ({e})") from None
    if config_path is None:
        raise ValueError(f"model {where}: no {CONFIG_FILE} beside it or in its parent folder (which params was it trained on?)")
    config = yaml.safe_load(config_path.read_text())
    side, algo = config.get("side"), config.get("algo")
    if side not in SIDES or algo not in SB3_ALGOS:
        raise ValueError(f"{config_path}: side/algo missing or invalid ({side!r}, {algo!r})")
    try:
        model = algorithms()[algo].load(zip_path, device=device)
    except Exception as e:  # a truncated or foreign zip: say which file
        raise ValueError(f"model {zip_path}: cannot load it as an SB3 {algo.upper()} model ({type(e).__name__}: {e})") from None
    params = _core.validate_params(config["params"])
    expected = observation_size(params, side)
    got = int(model.observation_space.shape[0])
    if got != expected:
        raise ValueError(f"model {zip_path}: it takes {got} observations, but this version of wolfpack gives the {side} {expected} on its params (trained on an older observation layout? retrain it)")
    return TrainedModel(zip_path, side, algo, params, config, model)


def observation_size(params: dict, side: str) -> int:
    """The observation length of ``side`` on ``params`` (the module docstring of
    :mod:`wolfpack.parallel_env` has the layout)."""
    batch = BatchEnv(params, num_envs=1, learners=side, seed=0, threads=1)
    return batch.wolf_obs_dim if side == "wolves" else batch.target_obs_dim


class Stopwatch:
    """Accumulates the seconds spent inside ``with`` blocks."""

    def __init__(self) -> None:
        self.total = 0.0

    def __enter__(self):
        self._t0 = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        self.total += time.perf_counter() - self._t0
