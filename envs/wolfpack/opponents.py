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

from wolfpack.models import find_model, load_policy, load_sb3, native_model_folders, read_config, run_label, sample_sb3
from wolfpack.sides import ACTION_MODES, OTHER_SIDE, SCRIPTED_LAWS, SIDES, bring_observation, law_side, mode_key, side_action_mode, side_observation


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
        if isinstance(policy, str) and law_side(policy) is not None:
            self.kind, self.law = "scripted", policy
            its_side = law_side(policy)
            if side is not None and side != its_side:
                raise ValueError(f"{role} {policy!r} is a law of the {its_side}, not of the {side}")
            side, label = its_side, policy
        elif isinstance(policy, (str, Path)) and native_model_folders(policy):
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
        (torch's global one would tie the opponent to the learner's random stream)."""
        if hasattr(self.model, "act") and hasattr(self.model, "obs_dim"):  # a wolfpack.models.SavedPolicy
            return self.model.act(obs, deterministic=False, rng=self._rng)
        return sample_sb3(self.model, obs, self._rng, f"opponent {self.name!r}")

    def __repr__(self) -> str:
        sampled = "" if self.deterministic else ", sampled"
        return f"Opponent({self.name!r}, {self.kind}, side={self.side!r}{sampled})"


def as_opponent(spec: Any) -> Opponent:
    """``spec`` as an :class:`Opponent` (an Opponent stays itself)."""
    return spec if isinstance(spec, Opponent) else Opponent(spec)


def opponent_side(opponent: Opponent, learners: str) -> str:
    """The side ``opponent`` drives when ``learners`` learn; ValueError when there is none or
    it would drive a side that learns."""
    if learners == "both":
        raise ValueError("opponent: with learners='both' both sides learn, so there is no side for an opponent to drive")
    free = OTHER_SIDE.get(learners)
    side = opponent.side or free
    if side is None:
        raise ValueError(f"opponent {opponent.name!r}: with learners='none' say which side it drives (Opponent(..., side='wolves' or 'targets'))")
    if learners in (side, "both"):
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
    driven = {"wolves": {"none": "wolves", "targets": "both"}, "targets": {"none": "targets", "wolves": "both"}}[side][learners]
    return driven, p
