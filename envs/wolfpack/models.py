"""Saved models as batched callables: :func:`load_policy` is the one loader for every model
wolfpack can save.

Two kinds of saved model exist:

- **the native trainer's** (``wolfpack train``): a *model folder* holds ``policy.pt`` (the
  actor's weights with its observation normaliser) and ``config.yaml`` (side, algorithm, the
  exact params, the recipe); a *run folder* holds one model folder per side that learned,
  ``RUN/wolves`` and ``RUN/targets`` (checkpoints: ``RUN/checkpoints/<agent steps>/<side>``);
- **Stable-Baselines3's** (``training/``): ``model.zip`` with ``config.yaml`` beside it, or any
  SB3 zip.

::

    import wolfpack
    policy = wolfpack.load_policy("runs/wolves")          # a run folder, a model folder or a zip
    actions = policy(obs)                                 # obs [..., D] float32 -> actions [..., 2]
    actions = policy.act(obs, deterministic=False, rng=np.random.default_rng(0))

Rows of ``obs`` are agents in wolfpack's order (a world's agents together, world after world),
which matters only for models trained with a one-hot agent id (``agent_id: true``); ``n`` must
then be a multiple of the side's agent count. ``policy.side``, ``policy.obs_dim``,
``policy.action_mode`` and ``policy.params`` say what the model was trained as and on. A model
given observations of another size is a ValueError naming both sizes.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from wolfpack._optional import require
from wolfpack.sides import SIDES, side_action_mode

#: Where a run folder keeps its model and its configuration (training/).
MODEL_FILE = "model.zip"
CONFIG_FILE = "config.yaml"


def read_config(path: Path) -> dict:
    """A model's ``config.yaml`` as a mapping (an empty file: {}); ValueError naming the file
    when it is not YAML or not a mapping of keys."""
    import yaml

    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file (a model's config.yaml is YAML)") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or "unreadable"
        raise ValueError(f"{path}: not valid YAML{at} ({problem}); a model's config.yaml is a mapping of keys (side, algo, network, params)") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        what = "a list" if isinstance(data, list) else f"the single value {_short_value(data)}"
        raise ValueError(f"{path}: holds {what}, not a mapping of keys (side, algo, network, params)")
    return data


def _short_value(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def find_model(where: str | Path) -> tuple[Path, Path | None]:
    """(the model's zip, its run's ``config.yaml`` or None) for a zip path (``.zip`` may be left
    out) or a run folder (``DIR/model.zip``); a checkpoint's run folder is its zip's parent or
    grandparent. FileNotFoundError naming the zip when there is none."""
    path = Path(where)
    zip_path = path / MODEL_FILE if path.is_dir() else (path if path.suffix == ".zip" else path.with_suffix(".zip"))
    if not zip_path.is_file():
        raise FileNotFoundError(zip_path)
    config = next((d / CONFIG_FILE for d in (zip_path.parent, zip_path.parent.parent) if (d / CONFIG_FILE).is_file()), None)
    return zip_path, config


def load_sb3(zip_path: Path, algo: str | None = None, device: str = "cpu"):
    """An SB3 model from its zip: with ``algo`` (``ppo``, ``sac``, ``a2c``, ``td3``) that class,
    else the class whose policy the zip holds. ValueError naming the file when it is no SB3
    model."""

    sb3 = require("stable_baselines3", f"loading the SB3 model {zip_path}")
    from stable_baselines3.common.save_util import load_from_zip_file

    classes = {"ppo": sb3.PPO, "sac": sb3.SAC, "a2c": sb3.A2C, "td3": sb3.TD3}
    try:
        if algo is None:
            data, _, _ = load_from_zip_file(zip_path, device=device, load_data=True)
            policy = getattr(data.get("policy_class"), "__module__", "") if data else ""
            algo = next((k for k in ("sac", "td3") if f".{k}." in f".{policy}."), "ppo")
        if algo not in classes:
            raise ValueError(f"unknown algorithm {algo!r} (one of {', '.join(classes)})")
        return classes[algo].load(zip_path, device=device)
    except Exception as e:  # a truncated or foreign zip: say which file
        raise ValueError(f"model {zip_path}: cannot load it as an SB3 model ({type(e).__name__}: {e})") from None


def sample_sb3(model: Any, obs: np.ndarray, rng: np.random.Generator, name: str) -> np.ndarray:
    """A draw from an SB3 model's (or policy's) action distribution with the generator ``rng``
    (torch's global one would tie the draw to a learner's random stream): Gaussian policies
    (PPO, A2C) mean + σ·ε, clipped to [-1, 1] as SB3 does; SAC's squashed Gaussian
    tanh(mean + σ·ε). ValueError naming ``name`` when the policy has no such distribution."""
    import torch

    policy = getattr(model, "policy", model)
    with torch.no_grad():
        t = torch.as_tensor(obs, device=policy.device)
        if hasattr(policy, "actor") and hasattr(policy.actor, "get_action_dist_params"):
            mean, log_std, _ = policy.actor.get_action_dist_params(t)
            mean, std = mean.cpu().numpy(), log_std.exp().cpu().numpy()
            return np.tanh(mean + std * rng.standard_normal(mean.shape))
        if not hasattr(policy, "get_distribution"):
            raise ValueError(f"{name}: cannot sample from a {type(policy).__name__} (use deterministic=True)")
        dist = policy.get_distribution(t).distribution
        if not (hasattr(dist, "mean") and hasattr(dist, "stddev")):
            raise ValueError(f"{name}: cannot sample from a {type(dist).__name__} distribution (use deterministic=True)")
        mean, std = dist.mean.cpu().numpy(), dist.stddev.cpu().numpy()
    return np.clip(mean + std * rng.standard_normal(mean.shape), -1.0, 1.0)


def run_label(zip_path: Path, config: dict) -> str:
    """``<kind>:<run folder>`` as training/evaluate.py names models (``ppo:wolves_ft``,
    ``imitation:wolves_bc``; a checkpoint adds its file: ``ppo:run/rollout_100000_steps``; a
    member of a selfplay.py league: ``ppo:<league folder>/<member>``)."""
    kind = "imitation" if "imitation_of" in config else str(config.get("algo", "sb3"))
    league = (config.get("league_member") or {}).get("league")
    if league and zip_path.name == MODEL_FILE:
        # Every league names its members wolves_g02, targets_g01...: the league tells them apart.
        return f"{kind}:{Path(league).name}/{zip_path.parent.name}"
    if zip_path.name == MODEL_FILE:
        return f"{kind}:{zip_path.parent.name}"
    run = zip_path.parent if (zip_path.parent / CONFIG_FILE).is_file() else zip_path.parent.parent
    return f"{kind}:{run.name}/{zip_path.stem}"


#: The native model folder's weights file.
POLICY_FILE = "policy.pt"


def native_model_folders(where: str | Path) -> dict[str, Path]:
    """``{side: model folder}`` of a native model folder (one side) or run folder (every side
    it holds); {} when ``where`` holds no native model."""
    path = Path(where)
    if not path.is_dir():
        return {}
    if (path / POLICY_FILE).is_file():
        config = _read_config(path)
        return {config.get("side"): path}
    return {side: path / side for side in SIDES if (path / side / POLICY_FILE).is_file()}


#: The keys of a native model's ``network:`` (the actor's shape, :class:`wolfpack.networks.mlp.Actor`).
NETWORK_KEYS = ("obs_dim", "agents", "hidden", "activation", "log_std_init", "agent_id", "norm_obs")
#: The same for a model over entity observations (``kind: entities``,
#: :class:`wolfpack.networks.sets.EntityActor`).
ENTITY_NETWORK_KEYS = ("kind", "self_dim", "row_size", "obs_dim", "hidden", "entity_width", "pool", "heads", "activation", "log_std_init", "norm_obs", "wall_rows")


def _read_config(folder: Path) -> dict:
    """A native model folder's ``config.yaml``, checked for what loading it needs: ``side``,
    ``algo``, ``network`` (the actor's shape) and ``params`` (what it was trained on).
    ValueError naming the file and what is wrong."""
    config_path = folder / CONFIG_FILE
    if not config_path.is_file():
        raise ValueError(f"model {folder}: no {CONFIG_FILE} beside {POLICY_FILE} (which params was it trained on?)")
    config = read_config(config_path)
    if config.get("side") not in SIDES:
        raise ValueError(f"model {folder}: {CONFIG_FILE} names no side ('wolves' or 'targets')")
    if not isinstance(config.get("algo"), str) or not config["algo"]:
        raise ValueError(f"{config_path}: no algo: (the algorithm that trained it, e.g. mappo)")
    network = config.get("network")
    if not isinstance(network, dict):
        raise ValueError(f"{config_path}: no network: mapping (the actor's shape: {', '.join(NETWORK_KEYS)})")
    keys = ENTITY_NETWORK_KEYS if network.get("kind") == "entities" else NETWORK_KEYS
    missing = [k for k in keys if k not in network and k != "wall_rows"]  # wall_rows: 0 when absent
    if missing or set(network) - set(keys):
        wrong = f"lacks {', '.join(missing)}" if missing else f"has unknown keys {', '.join(sorted(set(network) - set(keys)))}"
        raise ValueError(f"{config_path}: network: {wrong} (its keys are {', '.join(keys)})")
    obs_dim = network["obs_dim"]
    if not isinstance(obs_dim, int) or isinstance(obs_dim, bool) or obs_dim < 1:
        raise ValueError(f"{config_path}: network.obs_dim must be an integer >= 1, got {obs_dim!r}")
    params = config.get("params")
    if not isinstance(params, dict) or not isinstance(params.get("env"), dict):
        raise ValueError(f"{config_path}: no params: mapping with env: (the scenario it was trained on, which says what it observes)")
    return config


def load_tensors(path: Path, map_location: Any = "cpu") -> Any:
    """``torch.load(path, weights_only=True)``: tensors and plain containers only, never code.
    ValueError naming the file when it is truncated, corrupt, not a torch file, or holds
    anything else (torch's own advice to load it unsafely is not passed on)."""
    import pickle
    import warnings

    import torch

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # e.g. a pickle protocol other than torch's default
            return torch.load(path, map_location=map_location, weights_only=True)
    except (FileNotFoundError, PermissionError, IsADirectoryError):
        raise
    except pickle.UnpicklingError:
        raise ValueError(f"{path}: holds objects other than tensors; wolfpack loads only tensors from its .pt files (was it written by something else?)") from None
    except Exception:  # a truncated zip is an OSError, garbage a KeyError: the file, not the disk
        raise ValueError(f"{path}: cannot read it (truncated, corrupt or not a file torch wrote)") from None


def pick_side(folders: dict[str, Path], where: Any, side: str | None) -> str:
    """The side to load from a run folder's models: ``side`` when given (it must be there), else
    the only one; ValueError naming the choices otherwise."""
    if side is not None:
        if side not in folders:
            have = ", ".join(folders) or "none"
            raise ValueError(f"model {where}: holds no model of the {side} (it has: {have})")
        return side
    if len(folders) > 1:
        raise ValueError(f"model {where}: holds a model of each side; say which (side='wolves' or 'targets')")
    return next(iter(folders))


class SavedPolicy:
    """A saved model as a batched callable ``obs [n, D] -> actions [n, 2]`` (float32, in
    [-1, 1]); see the module docstring. Also answers SB3's ``predict(obs, deterministic)`` and
    carries ``observation_space`` / ``action_space``, so code written for SB3 models takes it."""

    def __init__(self, *, side: str, algo: str, obs_dim: int, config: dict, name: str, path: Path) -> None:
        import gymnasium

        self.side, self.algo, self.obs_dim, self.config, self.name, self.path = side, algo, obs_dim, config, name, path
        self.params: dict = config.get("params") or {}
        self.observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (obs_dim,), np.float32)
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32)

    @property
    def action_mode(self) -> str | None:
        """The mode its actions are in (its side's own mode in the params it was trained on)."""
        return side_action_mode(self.params, self.side) if "env" in self.params else None

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.act(obs)

    def predict(self, obs: np.ndarray, deterministic: bool = True, **_: Any) -> tuple[np.ndarray, None]:
        return self.act(obs, deterministic), None

    def accepts(self, dim: int) -> bool:
        """Whether observations of ``dim`` entries fit this model: its own size, or for a model
        over entity observations any size with its own features and whole rows (other
        capacities)."""
        return dim == self.obs_dim

    def check(self, obs: Any) -> np.ndarray:
        """``obs`` as float32 rows [n, D]; ValueError naming both sizes when D does not fit, or
        naming the row that holds NaN or inf (a native model would answer it with NaN actions,
        an SB3 one with an error from deep inside torch)."""
        x = np.ascontiguousarray(obs, dtype=np.float32)
        if x.ndim < 1 or not self.accepts(x.shape[-1]):
            raise ValueError(f"model {self.name!r} takes observations [n, {self.obs_dim}], got shape {tuple(x.shape)}")
        x = x.reshape(-1, x.shape[-1])
        finite = np.isfinite(x).all(axis=1)
        if not finite.all():
            raise ValueError(f"model {self.name!r}: observation row {int(np.argmin(finite))} holds NaN or inf")
        return x

    def act(self, obs: np.ndarray, deterministic: bool = True, rng: np.random.Generator | None = None) -> np.ndarray:
        """Actions [..., 2] for observations [..., D] (float32, clipped to [-1, 1]): the
        policy's mode, or with ``deterministic=False`` a draw with ``rng`` (a numpy
        ``Generator``; None: a fresh unseeded one). TypeError for a ``deterministic`` that is not
        True or False (``"no"`` would read as True) or an ``rng`` that is no generator."""
        if not isinstance(deterministic, (bool, np.bool_)):
            raise TypeError(f"deterministic must be True or False, got {deterministic!r}")
        if rng is not None and not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy random generator (np.random.default_rng(seed)) or None, got {rng!r}")
        x = self.check(obs)
        return self._act(x, deterministic, rng).reshape(*np.shape(obs)[:-1], 2)

    def _act(self, x: np.ndarray, deterministic: bool, rng: np.random.Generator | None) -> np.ndarray:
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, side={self.side!r}, obs_dim={self.obs_dim})"


class NativePolicy(SavedPolicy):
    """A model of the native trainer (``policy.pt`` + ``config.yaml``), run on the CPU."""

    def __init__(self, folder: Path, config: dict) -> None:

        require("torch", f"loading the model {folder}")
        from wolfpack.networks.sets import build_actor  # torch, only where a native model is loaded

        arch = config["network"]
        super().__init__(side=config["side"], algo=config["algo"], obs_dim=int(arch["obs_dim"]), config=config, name=native_label(folder, config), path=folder)
        #: The kinds of entity row it met in training (a model over entity observations).
        self.entity_kinds: list[str] | None = config.get("entity_kinds")
        try:
            self.actor = build_actor(arch)
        except Exception as e:  # a value of the wrong kind (hidden: "x", activation: "sigmoid")
            raise ValueError(f"{folder / CONFIG_FILE}: network: cannot build the actor from it ({_one_line(e)})") from None
        state = load_tensors(folder / POLICY_FILE)
        try:
            self.actor.load_state_dict(state)
        except Exception as e:  # another network's weights: say which file
            raise ValueError(f"model {folder}: {POLICY_FILE} does not fit the network in {CONFIG_FILE} ({_one_line(e)})") from None
        if not all(bool(p.isfinite().all()) for p in self.actor.state_dict().values() if p.is_floating_point()):
            raise ValueError(f"{folder / POLICY_FILE}: holds NaN or inf weights (damaged, or saved from a run that diverged)")
        self.actor.eval()

    def accepts(self, dim: int) -> bool:
        return self.actor.accepts(dim)

    def _act(self, x: np.ndarray, deterministic: bool, rng: np.random.Generator | None) -> np.ndarray:
        """The clipped mean, or a draw mean + σ·ε (ε from ``rng``, default a fresh unseeded
        generator), clipped."""
        import torch

        if self.actor.agent_id and x.shape[0] % self.actor.agents:
            raise ValueError(f"model {self.name!r} uses agent ids: give whole worlds ({self.actor.agents} rows each), got {x.shape[0]} rows")
        if deterministic:
            return self.actor.deterministic(torch.from_numpy(x)).numpy()
        with torch.no_grad():
            mean = self.actor.mean(self.actor.norm(torch.from_numpy(x))).numpy()
            std = self.actor.log_std.exp().numpy()
        rng = rng if rng is not None else np.random.default_rng()
        mean = mean + std * rng.standard_normal(mean.shape).astype(np.float32)
        return np.clip(mean, -1.0, 1.0).astype(np.float32, copy=False)


class SB3Policy(SavedPolicy):
    """A Stable-Baselines3 model (a zip, with its run's ``config.yaml`` when there is one)."""

    def __init__(self, zip_path: Path, config: dict) -> None:
        self.model = load_sb3(zip_path, config.get("algo"))
        shape = getattr(self.model.observation_space, "shape", None)
        if shape is None or len(shape) != 1:
            raise ValueError(f"model {zip_path}: observations of shape {shape}; wolfpack's are vectors")
        label = run_label(zip_path, config) if config else zip_path.stem
        super().__init__(side=config.get("side"), algo=config.get("algo", "sb3"), obs_dim=int(shape[0]), config=config, name=label, path=zip_path)

    def _act(self, x: np.ndarray, deterministic: bool, rng: np.random.Generator | None) -> np.ndarray:
        if deterministic or rng is None:
            actions, _ = self.model.predict(x, deterministic=deterministic)
            return np.clip(np.asarray(actions, dtype=np.float32), -1.0, 1.0)
        return sample_sb3(self.model, x, rng, f"model {self.name!r}").astype(np.float32)


def _one_line(e: BaseException) -> str:
    text = " ".join(str(e).split())
    return text if len(text) <= 200 else text[:197] + "..."


def native_label(folder: Path, config: dict) -> str:
    """``<algo>:<run>`` (``mappo:wolves``); a both-sides run adds the side (``mappo:both/wolves``),
    a checkpoint its agent steps (``mappo:wolves@1228800``). A league's runs, named after their
    side (``<league>/iter3/wolves``, ``<league>/final/targets``), are named with the league and
    the step (``mappo:<league>/final/targets``)."""
    run = Path(config.get("run") or folder.parent)
    league_run = run.name in SIDES and re.fullmatch(r"iter\d+|final", run.parent.name) is not None
    name = f"{run.parent.parent.name}/{run.parent.name}/{run.name}" if league_run else run.name
    label = f"{config['algo']}:{name}"
    if config.get("learners") == "both":
        label += f"/{config['side']}"
    if config.get("checkpoint_steps") is not None:
        label += f"@{config['checkpoint_steps']}"
    return label


def load_policy(where: str | Path, side: str | None = None) -> SavedPolicy:
    """Any saved model as a :class:`SavedPolicy`: a native run or model folder (``side`` picks
    one of a run's sides; required when it holds both), an SB3 run folder or zip. ValueError
    naming the path when there is no model there, it cannot be read, or it is of another side."""
    if side is not None and side not in SIDES:
        raise ValueError(f"side must be 'wolves' or 'targets', got {side!r}")
    folders = native_model_folders(where)
    if folders:
        chosen = pick_side(folders, where, side)
        config = _read_config(folders[chosen])
        return NativePolicy(folders[chosen], config)
    try:
        zip_path, config_path = find_model(where)
    except FileNotFoundError:
        raise ValueError(f"model {where}: no model there (a run folder of 'wolfpack train', its model folder, or an SB3 model.zip)") from None
    config = read_config(config_path) if config_path is not None else {}
    policy = SB3Policy(zip_path, config)
    if side is not None and policy.side not in (None, side):
        raise ValueError(f"model {where}: trained for the {policy.side}, not the {side}")
    return policy


def expand_models(paths: list[str]) -> list[str]:
    """Run folders and zips as they are; a selfplay.py league folder becomes its learned
    members (those it trained; the models it borrowed are given on their own); a run of
    ``wolfpack train`` in which both sides learned becomes its two models."""
    out = []
    for p in paths:
        league = Path(p) / "league.json"
        native = native_model_folders(p)
        if len(native) > 1:
            out += [str(folder) for folder in native.values()]
        elif league.is_file():
            doc = json.loads(league.read_text())
            out += [str(Path(p) / m["path"]) for m in doc["members"] if m["kind"] == "model" and not m.get("fixed")]
        else:
            out.append(p)
    return out
