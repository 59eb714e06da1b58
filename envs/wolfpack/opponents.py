"""Opponents: what drives the side that does not learn.

Every env (:class:`wolfpack.BatchEnv`, :func:`wolfpack.make_vec_env`, :func:`wolfpack.parallel_env`)
takes ``opponent=``, one of

- **a scripted law by name**: wolves ``"seed000"``, ``"bvc"``, ``"formation"``; targets
  ``"escape"``, ``"random"``, ``"still"``. It runs inside the core, exactly as ``policies.*``
  in params does (the name sets that key);
- **a model of the native trainer** (``wolfpack train``): its run folder, or one side's model
  folder in it (``RUN/targets``); a run in which both sides learned needs ``side=`` (or the
  side's folder), as it holds a model of each (:mod:`wolfpack.models`);
- **a saved Stable-Baselines3 model**: the path of a ``.zip`` or of a run folder of
  ``training/`` (``model.zip`` + ``config.yaml``; a checkpoint's run folder is its zip's parent
  or grandparent), or a loaded model (``BaseAlgorithm``) or policy (``BasePolicy``);
- **any batched callable** ``obs [n, D] float32 -> actions [n, 2]`` (values in [-1, 1], clipped);
- an :class:`Opponent` wrapping one of these with options: ``deterministic=False`` (sample from
  the policy's action distribution with a numpy generator seeded ``seed``, so that sampled
  rollouts repeat too), ``action_mode`` (how its actions are read; a model from a run folder
  brings its own), ``side`` (which side it drives, needed with ``learners="none"``), ``name``.

A learned opponent is evaluated once per step for all its agents in all worlds: one batched call
(one forward pass) on the observations its side would have as a learner. Autoreset and infos
are those of a scripted opponent; the opponent's observations never appear in the outputs.
Its actions are read in its own action mode (``env.wolf_action_mode`` /
``env.target_action_mode``), so a wolf model trained in velocity mode can meet a target
model trained in unicycle mode. Likewise a wolf model trained with the pack's last sighting in
its observation (``env.last_sighting``) switches it on in the worlds it plays in: it adds to the
wolves' observations only, so the other side observes what it always did.

Bad opponents are ValueErrors: an observation or action size that does not fit the side it
drives (both sizes named), an opponent for a side that learns, a callable that returns NaN or
the wrong shape (the opponent named).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

import numpy as np

from wolfpack import _core

SIDES = ("wolves", "targets")
#: The scripted laws each side can follow, by name (the core's own lists).
SCRIPTED_LAWS: dict[str, tuple[str, ...]] = {"wolves": tuple(_core.WOLF_LAWS), "targets": tuple(_core.TARGET_LAWS)}
ACTION_MODES = ("unicycle", "velocity")
#: Where a run folder keeps its model and its configuration (training/).
MODEL_FILE = "model.zip"
CONFIG_FILE = "config.yaml"


def mode_key(side: str) -> str:
    """The params key under ``env`` of ``side``'s own action mode."""
    return "wolf_action_mode" if side == "wolves" else "target_action_mode"


#: The learning-interface keys (params ``env.*``) that shape one side's observation only: a model
#: brings its own values of its side's keys into any world it plays in.
SIDE_OBSERVATION_KEYS = {"wolves": ("last_sighting",), "targets": ()}
#: Each side's own observation layout key (``flat`` or ``entities``) under ``env``.
LAYOUT_KEY = {"wolves": "wolf_observation", "targets": "target_observation"}
#: The capacities of entity observations (``env.entities``) a model may meet larger.
ENTITY_CAPACITIES = ("max_wolves", "max_targets", "max_obstacles")


def side_observation(params: dict, side: str) -> dict:
    """``side``'s own observation keys as set in ``params`` (a model's training params; a key
    they lack is off, as in params.yaml): :data:`SIDE_OBSERVATION_KEYS`, its layout
    (``wolf_observation`` / ``target_observation``: its own, else ``observation``, else flat)
    and, for an entity layout, ``entities`` (its capacities and range)."""
    env = (params or {}).get("env") or {}
    keys: dict[str, Any] = {key: bool(env.get(key, False)) for key in SIDE_OBSERVATION_KEYS[side]}
    layout = env.get(LAYOUT_KEY[side]) or env.get("observation") or "flat"
    keys[LAYOUT_KEY[side]] = layout
    if layout == "entities":
        keys["entities"] = dict(env.get("entities") or {})
    return keys


def bring_observation(params: dict, observation: dict) -> None:
    """Sets a model's own observation keys (:func:`side_observation`) in the ``env`` section of
    ``params``, the params it plays in. Entity capacities become the largest of the model's, the
    world's and the world's team sizes: a set network reads any number of rows, and the world
    may hold more agents than the model was trained with."""
    env = params["env"]
    for key, value in observation.items():
        if key in LAYOUT_KEY.values():
            # Set only where it changes the side's layout: an unchanged layout keeps the params
            # as they were (a league swaps opponents mid-episode only while the world's params
            # stay the same).
            if value != (env.get(key) or env.get("observation") or "flat"):
                env[key] = value
            continue
        if key != "entities":
            env[key] = value
            continue
        mine = dict(env.get("entities") or {})
        merged = {**mine, **value}
        for cap in ENTITY_CAPACITIES:
            if cap in mine and cap in value:
                merged[cap] = max(int(mine[cap]), int(value[cap]))
        world = params.get("world") or {}
        for cap, count in (("max_wolves", world.get("wolves")), ("max_targets", world.get("targets"))):
            if isinstance(count, int) and cap in merged:
                merged[cap] = max(int(merged[cap]), count)
        env["entities"] = merged


def side_action_mode(params: dict, side: str) -> str:
    """How ``side`` reads its actions on ``params``: its own mode, else ``env.action_mode``."""
    env = params["env"]
    return env.get(mode_key(side)) or env["action_mode"]


def _law_side(name: str) -> str | None:
    return next((side for side, laws in SCRIPTED_LAWS.items() if name in laws), None)


def _is_native(where: str | Path) -> bool:
    """Whether ``where`` holds a model of the native trainer (``wolfpack train``)."""
    from wolfpack.models import native_model_folders

    return bool(native_model_folders(where))


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
    from wolfpack._optional import require

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


class Opponent:
    """One side's driver (see the module docstring).

    Args:
        policy: a scripted law's name, a model path, an SB3 model or policy, or a callable
            ``obs [n, D] -> actions [n, 2]``.
        side: ``"wolves"`` or ``"targets"``; None: the side not learning (a law's name and a
            run folder's ``config.yaml`` know theirs).
        deterministic: True: the policy's mode (the Gaussian mean); False: sampled.
        seed: seeds the sampling generator (``deterministic=False``).
        action_mode: ``"unicycle"`` or ``"velocity"``, the mode its actions are in; None: a
            run folder's own, else the env's.
        name: the label in tables and errors (default: the law, ``<algo>:<run folder>``, a
            loaded model's own name, or the callable's name).
        role: what errors call it while it is built (``"policy"`` where it is the policy being
            scored or recorded).

    Attributes: ``kind`` (``"scripted"``, ``"model"`` or ``"callable"``), ``law`` (scripted),
    ``obs_dim`` (the observation size a model takes, None for a callable), ``config`` (a run
    folder's configuration, else {}), ``model`` (the SB3 model or policy, else None).
    """

    def __init__(
        self,
        policy: Any,
        *,
        side: str | None = None,
        deterministic: bool = True,
        seed: int = 0,
        action_mode: str | None = None,
        name: str | None = None,
        role: str = "opponent",
    ) -> None:
        if side is not None and side not in SIDES:
            raise ValueError(f"opponent side must be 'wolves' or 'targets', got {side!r}")
        if action_mode is not None and action_mode not in ACTION_MODES:
            raise ValueError(f"opponent action_mode must be 'unicycle' or 'velocity', got {action_mode!r}")
        if not isinstance(deterministic, bool):
            raise ValueError(f"opponent deterministic must be True or False, got {deterministic!r}")
        self.deterministic = deterministic
        self.seed = seed
        self._rng = np.random.default_rng(seed)
        self.law: str | None = None
        self.config: dict = {}
        self.model: Any = None
        self.obs_dim: int | None = None
        #: The kinds of entity row a model over entity observations met in training (None: any).
        self.entity_kinds: list[str] | None = None
        self._call: Callable[[np.ndarray], np.ndarray] | None = None
        #: Its side's observation keys from its training params (a model from a folder).
        self.observation: dict = {}
        trained: dict = {}
        mode = action_mode
        if isinstance(policy, Opponent):
            raise TypeError("opponent: already an Opponent (give its policy, or use it as it is)")
        if isinstance(policy, str) and _law_side(policy) is not None:
            self.kind, self.law = "scripted", policy
            law_side = _law_side(policy)
            if side is not None and side != law_side:
                raise ValueError(f"{role} {policy!r} is a law of the {law_side}, not of the {side}")
            side, label = law_side, policy
        elif isinstance(policy, (str, Path)) and _is_native(policy):
            from wolfpack.models import load_policy

            self.kind = "model"
            self.model = load_policy(policy, side)
            self.config = self.model.config
            trained = self.model.params
            side = self.model.side
            if mode is None:
                mode = self.model.action_mode
            label = self.model.name
        elif isinstance(policy, (str, Path)):
            self.kind = "model"
            try:
                zip_path, config_path = find_model(policy)
            except FileNotFoundError as e:
                raise ValueError(f"{role} {str(policy)!r}: not a scripted law ({', '.join(SCRIPTED_LAWS['wolves'] + SCRIPTED_LAWS['targets'])}) and no model file there ({e})") from None
            if config_path is not None:
                self.config = read_config(config_path)
            self.model = load_sb3(zip_path, self.config.get("algo"))
            trained_side = self.config.get("side")
            if trained_side in SIDES:
                if side is not None and side != trained_side:
                    raise ValueError(f"{role} {zip_path}: trained for the {trained_side}, asked to drive the {side}")
                side = trained_side
            trained = self.config.get("params") or {}
            if mode is None and "env" in trained:
                mode = side_action_mode(trained, side) if side else trained["env"].get("action_mode")
            label = run_label(zip_path, self.config) if self.config else zip_path.stem
        elif callable(getattr(policy, "predict", None)) and hasattr(policy, "observation_space"):
            self.kind, self.model = "model", policy
            # A wolfpack.load_policy model knows its name; an SB3 model only its class.
            label = policy.name if isinstance(getattr(policy, "name", None), str) else type(policy).__name__
        elif callable(policy):
            self.kind, self._call = "callable", policy
            label = getattr(policy, "__name__", type(policy).__name__)
        else:
            raise TypeError(f"{role} must be a law's name, a model path, an SB3 model or policy, or a callable obs -> actions; got {type(policy).__name__}")
        if self.model is not None:
            self._check_spaces(role)
            self.entity_kinds = getattr(self.model, "entity_kinds", None)
        self.side = side
        self.action_mode = mode
        if side is not None and trained:
            self.observation = side_observation(trained, side)
        self.name = name or label

    def _check_spaces(self, role: str) -> None:
        obs_space, act_space = self.model.observation_space, self.model.action_space
        if getattr(obs_space, "shape", None) is None or len(obs_space.shape) != 1:
            raise ValueError(f"{role}: a model with observations of shape {getattr(obs_space, 'shape', None)}; wolfpack's are vectors")
        if getattr(act_space, "shape", None) != (2,):
            raise ValueError(f"{role}: the model's actions have shape {getattr(act_space, 'shape', None)}, a wolfpack agent's action has 2 entries")
        self.obs_dim = int(obs_space.shape[0])

    def fits(self, dim: int) -> bool:
        """Whether observations of ``dim`` entries fit it (a callable: any; a model over entity
        observations: any capacities, :meth:`wolfpack.models.SavedPolicy.accepts`)."""
        if self.obs_dim is None:
            return True
        accepts = getattr(self.model, "accepts", None)
        return accepts(dim) if accepts is not None else dim == self.obs_dim

    @property
    def learned(self) -> bool:
        """Whether it runs outside the core (a model or a callable)."""
        return self.kind != "scripted"

    def reseed(self, seed: int) -> None:
        """Restarts the sampling generator (``deterministic=False``) at ``seed``."""
        self.seed = seed
        self._rng = np.random.default_rng(seed)

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Actions for observations [n, D] → float32 [n, 2], checked (ValueError naming this
        opponent when the shape is wrong or a value is not finite)."""
        if self.kind == "scripted":
            raise RuntimeError(f"opponent {self.name!r} is a scripted law: it runs inside the core")
        obs = np.ascontiguousarray(obs, dtype=np.float32)
        raw = self._call(obs) if self._call is not None else self._policy_actions(obs)
        a = np.asarray(raw)
        if a.dtype.kind not in "fiu":
            raise ValueError(f"opponent {self.name!r} returned actions of dtype {a.dtype}, expected numbers")
        if a.shape != (obs.shape[0], 2):
            raise ValueError(f"opponent {self.name!r} returned actions of shape {a.shape} for {obs.shape[0]} observations, expected {(obs.shape[0], 2)}")
        if not np.isfinite(a).all():
            k = int(np.argmax(~np.isfinite(a).all(axis=1)))
            raise ValueError(f"opponent {self.name!r} returned a non-finite action for observation {k}: {a[k].tolist()}")
        return np.ascontiguousarray(a, dtype=np.float32)

    def _policy_actions(self, obs: np.ndarray) -> np.ndarray:
        if self.deterministic:
            actions, _ = self.model.predict(obs, deterministic=True)
            return np.clip(actions, -1.0, 1.0)
        return self._sampled(obs)

    def _sampled(self, obs: np.ndarray) -> np.ndarray:
        """A draw from the policy's action distribution with this opponent's own generator
        (torch's global one would tie the opponent to the learner's random stream): Gaussian
        policies (PPO, A2C) mean + σ·ε, clipped to [-1, 1] as SB3 does; SAC's squashed
        Gaussian tanh(mean + σ·ε)."""
        if hasattr(self.model, "act") and hasattr(self.model, "obs_dim"):  # a wolfpack.models.SavedPolicy
            return self.model.act(obs, deterministic=False, rng=self._rng)
        import torch

        policy = getattr(self.model, "policy", self.model)
        with torch.no_grad():
            t = torch.as_tensor(obs, device=policy.device)
            if hasattr(policy, "actor") and hasattr(policy.actor, "get_action_dist_params"):
                mean, log_std, _ = policy.actor.get_action_dist_params(t)
                mean, std = mean.cpu().numpy(), log_std.exp().cpu().numpy()
                return np.tanh(mean + std * self._rng.standard_normal(mean.shape))
            if not hasattr(policy, "get_distribution"):
                raise ValueError(f"opponent {self.name!r}: cannot sample from a {type(policy).__name__} (use deterministic=True)")
            dist = policy.get_distribution(t).distribution
            if not (hasattr(dist, "mean") and hasattr(dist, "stddev")):
                raise ValueError(f"opponent {self.name!r}: cannot sample from a {type(dist).__name__} distribution (use deterministic=True)")
            mean, std = dist.mean.cpu().numpy(), dist.stddev.cpu().numpy()
        return np.clip(mean + std * self._rng.standard_normal(mean.shape), -1.0, 1.0)

    def __repr__(self) -> str:
        sampled = "" if self.deterministic else ", sampled"
        return f"Opponent({self.name!r}, {self.kind}, side={self.side!r}{sampled})"


def as_opponent(spec: Any) -> Opponent:
    """``spec`` as an :class:`Opponent` (an Opponent stays itself)."""
    return spec if isinstance(spec, Opponent) else Opponent(spec)


def opponent_side(opponent: Opponent, learners: str) -> str:
    """The side ``opponent`` drives when ``learners`` learn; ValueError when there is none or
    it would drive a side that learns."""
    if learners == "all":
        raise ValueError("opponent: with learners='all' both sides learn, so there is no side for an opponent to drive")
    free = {"wolves": "targets", "targets": "wolves"}.get(learners)
    side = opponent.side or free
    if side is None:
        raise ValueError(f"opponent {opponent.name!r}: with learners='none' say which side it drives (Opponent(..., side='wolves' or 'targets'))")
    if learners in (side, "all"):
        raise ValueError(f"opponent {opponent.name!r} drives the {side}, but the {side} learn here (learners={learners!r}); an opponent drives the side that does not learn")
    return side


def drivers(params: dict, learners: str, opponent: Opponent | None) -> tuple[str, dict]:
    """(the core's learners, its params) for ``learners`` against ``opponent``: a scripted
    opponent sets its side's law; a learned one makes its side driven from Python, read in its
    action mode."""
    if opponent is None:
        return learners, params
    side = opponent_side(opponent, learners)
    p = json.loads(json.dumps(params))
    key = mode_key(side)
    if not opponent.learned:
        p["policies"][side] = opponent.law
        return learners, p
    if opponent.action_mode is not None:  # else the params' mode for that side
        p["env"][key] = opponent.action_mode
    bring_observation(p, opponent.observation)
    driven = {"wolves": {"none": "wolves", "targets": "all"}, "targets": {"none": "targets", "wolves": "all"}}[side][learners]
    return driven, p
