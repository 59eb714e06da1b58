"""The native batch: ``E`` worlds stepped together in Rust, the engine behind every adapter.

:class:`BatchEnv` is the fastest way to roll out wolfpack: one call steps all worlds on a
thread pool with the GIL released, the scripted side runs inside the core, and the outputs land
in fresh numpy arrays or in the caller's own (``step(out=...)``). The PettingZoo, Gymnasium and
SB3 environments are thin views of it.
Observations, actions and rewards are documented in :mod:`wolfpack.parallel_env`.
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from wolfpack import _core
from wolfpack._checks import check_flag, check_index, check_int, check_seed, check_threads
from wolfpack.config import apply_overrides, check_tree, load_params
from wolfpack.opponents import Opponent, as_opponent, drivers, opponent_side
from wolfpack.sides import SIDES, check_learners
from wolfpack.task import task_params

#: The outcome codes → names, for :meth:`BatchEnv.step`'s ``outcome`` array and every env's
#: ``infos[...]["outcome"]``: 0 ``running``, 1 ``captured`` (every target captured), 2
#: ``collision`` (a wolf touched an obstacle or a wolf), 3 ``timeout`` (``world.max_steps``), 4
#: ``cornered`` (every target captured or cornered, at least one cornered; only with
#: ``capture.cornered: true``). ``wolfpack.OUTCOMES.index("captured")`` gives a code back.
OUTCOMES: tuple[str, ...] = tuple(_core.OUTCOMES)


#: Keyword aliases the env constructors accept for params keys (PettingZoo's name first).
KEYWORD_ALIASES = {"max_cycles": "world.max_steps"}


def dotted_keys(overrides: Mapping[str, Any]) -> dict:
    """Override keys as dotted params keys: ``world__wolves`` → ``world.wolves``, aliases of
    :data:`KEYWORD_ALIASES` resolved."""
    return {KEYWORD_ALIASES.get(k, str(k).replace("__", ".")): v for k, v in overrides.items()}


def check_override_keywords(overrides: Mapping[str, Any]) -> None:
    """Constructor keywords must name params keys: one that names no params key (nor an alias
    in :data:`KEYWORD_ALIASES`) is a TypeError naming it, as Python does for any unknown
    keyword argument (libraries such as TorchRL rely on that to retry without it)."""
    known = _core.default_params()
    unknown = []
    for k, key in zip(overrides, dotted_keys(overrides)):
        node = known
        for part in key.split("."):
            node = node.get(part, _MISSING) if isinstance(node, dict) else _MISSING
        if node is _MISSING:
            unknown.append(k)
    if unknown:
        # Python's own wording for the first, which libraries match on (TorchRL's GymEnv retries
        # without `frameskip` when it reads "unexpected keyword argument 'frameskip'").
        also = f" (and {', '.join(repr(k) for k in unknown[1:])})" if len(unknown) > 1 else ""
        close = difflib.get_close_matches(dotted_keys({unknown[0]: None}).popitem()[0], [*_leaf_keys(known), *KEYWORD_ALIASES], n=3, cutoff=0.75)
        hint = f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""
        raise TypeError(
            f"got an unexpected keyword argument {unknown[0]!r}{also}{hint}. A keyword names a params key, "
            f"with __ for the dots (world__wolves=8) or dotted (**{{'world.wolves': 8}}), or is one of "
            f"{', '.join(KEYWORD_ALIASES)}"
        )


def _leaf_keys(node: Mapping[str, Any], prefix: str = "") -> list[str]:
    """Every dotted params key under ``node`` (sections and their leaves)."""
    keys = []
    for k, v in node.items():
        keys.append(prefix + k)
        if isinstance(v, dict):
            keys += _leaf_keys(v, f"{prefix}{k}.")
    return keys


_MISSING = object()


def resolve_params(params: str | Path | Mapping[str, Any] | None, overrides: Mapping[str, Any], task: str | None = None) -> dict:
    """``params`` (None: the documented scenario; a path to YAML; or a dict), or the params of
    ``task`` (a name of :func:`wolfpack.tasks`; not with ``params``), with ``overrides``
    applied, validated. Override keys are dotted (``"world.wolves"``) or use ``__`` in place of
    the dots (``world__wolves=8`` as a keyword argument); ``max_cycles`` is PettingZoo's name
    for ``world.max_steps``. An unknown key or a bad value is a ValueError naming the key (the
    env constructors check their keywords first: :func:`check_override_keywords`). A params
    dict or override nested too deeply or too large is a ValueError too
    (:func:`wolfpack.config.check_tree`); ``params`` of another type is a TypeError."""
    dotted = dotted_keys(overrides)
    if task is not None:
        if params is not None:
            raise ValueError(f"give params or task, not both (task {task!r} is a complete params file)")
        return task_params(task, dotted)
    if params is None or isinstance(params, (str, Path)):
        return load_params(params, dotted)
    if not isinstance(params, Mapping):
        raise TypeError(f"params must be None, a path or a dict, got {type(params).__name__}")
    return _core.validate_params(apply_overrides(dict(params), dotted))


def observation_layout(side: str, params: str | Path | Mapping[str, Any] | None = None, *, task: str | None = None, **overrides: Any) -> list[dict[str, Any]]:
    """The blocks of ``side``'s observation (``"wolves"`` or ``"targets"``) under ``params`` (or
    ``task``, with ``overrides`` on top, as :class:`BatchEnv` takes them), in order: dicts
    ``{"name", "start", "size"}`` that tile the observation — ``speed``, ``turn_rate``,
    ``heading``, ``walls``, ``clock``, then the side's own blocks (wolves: ``targets``,
    ``wolves``, ``lidar``, ``last_sighting`` with ``env.last_sighting``; targets: ``speed_cap``,
    ``wolves``, ``lidar``) and ``interaction`` with ``env.interaction_row``. The table of
    docs/interface.md ("Observations") says what each entry means; the core writes by this
    layout, so a slice taken from it stays right when the params change the sizes.

    With entity observations for ``side`` (``env.observation`` or its side's own key set to
    ``entities``), the own-feature blocks are followed by ``wolf_rows``, ``target_rows``,
    ``obstacle_rows`` and ``wall_rows``, each with ``rows`` (its capacity) and ``row_size``
    (the entries of a row, named by :data:`ENTITY_FIELDS`; docs/interface.md, "Entity
    observations")."""
    if side not in SIDES:
        raise ValueError(f"side must be 'wolves' or 'targets', got {side!r}")
    check_override_keywords(overrides)
    return _core.observation_layout(resolve_params(params, overrides, task), side)


#: The entries of an entity row and of an entity state row, in order (the core's lists).
ENTITY_FIELDS: tuple[str, ...] = tuple(_core.ENTITY_FIELDS)
ENTITY_STATE_FIELDS: tuple[str, ...] = tuple(_core.ENTITY_STATE_FIELDS)


def entity_kinds(side: str, params: Mapping[str, Any]) -> set[str]:
    """The kinds of entity row ``side``'s observation can hold under ``params``: ``wolf``,
    ``target``, ``obstacle``, ``wall`` (a wolf of a lone wolf's pack sees no other wolf; a
    target sees other targets only where there are several; no obstacle rows without
    obstacles or obstacle capacity)."""
    world, obstacles = params["world"], params["obstacles"]
    others = {"wolves": (world["wolves"] - 1, world["targets"]), "targets": (world["wolves"], world["targets"] - 1)}[side]
    total = sum(int(obstacles[k]) for k in ("static_circles", "moving_circles", "static_polygons", "moving_polygons"))
    kinds = {"wall"}
    kinds |= {"wolf"} if others[0] > 0 else set()
    kinds |= {"target"} if others[1] > 0 else set()
    kinds |= {"obstacle"} if total > 0 and params["env"]["entities"]["max_obstacles"] > 0 else set()
    return kinds


def entity_shape(side: str, params: Mapping[str, Any]) -> tuple[int, int] | None:
    """``(own features, row size)`` of ``side``'s entity observation under validated
    ``params``; None when that side observes the flat layout."""
    rows = [b for b in _core.observation_layout(params, side) if "rows" in b]
    return (rows[0]["start"], rows[0]["row_size"]) if rows else None


def first_cornered_step(steps) -> int:
    """The first step at which any target of a world was cornered, from its ``cornered_step``
    row of a :meth:`BatchEnv.step` output (−1 per target that never was); −1 if none was."""
    seen = [int(c) for c in steps if c >= 0]
    return min(seen) if seen else -1


class ObservationSizeError(ValueError):
    """A learned opponent built for another observation size than its side has here (other
    params: agent counts, lidar rays, observation keys)."""

    def __init__(self, message: str, wanted: int, here: int, reason: str | None = None) -> None:
        super().__init__(message)
        self.wanted, self.here = wanted, here
        #: Why it does not fit, in a few words (a table's cell); None: the sizes say it.
        self.reason = reason


class BatchEnv:
    """``num_envs`` worlds in one native batch.

    Args:
        params: None (the documented scenario), a YAML path, or a params dict.
        task: a task of the benchmark suite instead of ``params`` (:func:`wolfpack.tasks`,
            docs/tasks.md); ``overrides`` change it. An unknown name is a ValueError.
        num_envs: number of worlds E; world i is seeded ``seed + i``.
        learners: ``"wolves"``, ``"targets"``, ``"both"`` (``"all"`` also names it) or
            ``"none"``; the other side follows its scripted law (``policies.*`` in params).
        seed: base seed, an integer with ``seed + num_envs - 1 < 2**64``.
        autoreset: reset a finished world within the same step (SB3's convention), keeping
            its last observation in ``final_obs_*``.
        with_state: every reset and step also returns ``state`` [E, state_dim] (what
            :meth:`state` would return after it, written by each world's own task) and, with
            ``autoreset``, ``final_state`` [E, state_dim]: the global state a world ended its
            episode in, before its reset (zeros where no episode ended) — what a centralised
            critic bootstraps from when an episode was truncated. Off by default: one or two
            arrays more per step.
        threads: worker threads (None: all cores; at most 256). Results never depend on it.
        opponent: what drives the side that does not learn (:mod:`wolfpack.opponents`): None
            (its law in params), a scripted law's name, a model path, an SB3 model or policy,
            a callable ``obs [n, D] -> actions [n, 2]``, or a :class:`wolfpack.Opponent`. A
            learned opponent is one batched call per step for all its agents in all worlds;
            its observations never appear in the outputs. Swap it with
            :meth:`set_opponent`. With ``learners="none"`` it must say its side.
        **overrides: params overrides, ``world__wolves=8`` or ``**{"world.wolves": 8}``.

    A wrong type (a str seed, a float ``num_envs``, a bool where a number is meant) is a
    TypeError; a bad value (a seed out of range, ``num_envs < 1``, ``threads=0``, a flag that is
    not True or False, a bad params key) is a ValueError naming it.

    :meth:`reset` and :meth:`step` return a dict of fresh arrays (or, with ``step(out=...)``,
    the caller's arrays from :meth:`new_outputs`, written in place): ``obs_wolves`` [E, N, Dw]
    (when wolves learn), ``obs_targets`` [E, M, Dt] (when targets learn), ``rewards_wolves``
    [E, N] and ``rewards_targets`` [E, M] (both sides always, the scripted one too, so that
    evaluations can report its return), ``terminated`` / ``truncated`` [E] bool,
    ``final_obs_*`` (autoreset; valid where the episode ended), ``state`` and ``final_state`` [E, S]
    (with ``with_state=True``), and the infos of the episode the
    step belongs to: ``outcome`` [E] uint8 (see :data:`OUTCOMES`), ``steps`` [E],
    ``capture_step`` [E, M] (−1: not captured; with ``capture.cornered``, a cornered target's
    end counts), ``cornered_step`` [E, M] (first step each target was cornered, −1: never),
    ``energy``, ``collisions``, ``distance``
    [E, N+M] (wolves: to the nearest uncaptured target; targets: to the nearest wolf).
    """

    def __init__(
        self,
        params: str | Path | Mapping[str, Any] | None = None,
        *,
        task: str | None = None,
        num_envs: int = 1,
        learners: str = "wolves",
        seed: int = 0,
        autoreset: bool = True,
        threads: int | None = None,
        opponent: Any = None,
        with_state: bool = False,
        **overrides: Any,
    ) -> None:
        self._init_kwargs = dict(params=params, task=task, num_envs=num_envs, learners=learners, seed=seed, autoreset=autoreset, threads=threads, opponent=opponent, with_state=with_state, **overrides)
        self.learners = check_learners(learners)
        num_envs = check_int(num_envs, "num_envs", 1)
        threads = check_threads(threads)
        seed = check_seed(seed, span=num_envs)
        autoreset = check_flag(autoreset, "autoreset")
        with_state = check_flag(with_state, "with_state")
        check_override_keywords(overrides)
        self._base_params = resolve_params(params, overrides, task)
        #: The task these worlds play (None: ``params``); with overrides outside ``policies``,
        #: ``env`` and ``rewards`` it is a modified task (:func:`wolfpack.task.outcome_changes`).
        self.task: str | None = task
        self.opponent: Opponent | None = as_opponent(opponent) if opponent is not None else None
        core_learners, core_params = drivers(self._base_params, self.learners, self.opponent)
        self._core = _core.BatchEnv(core_params, num_envs, core_learners, seed, autoreset, threads, with_state)
        # The worlds exist from here (step() works on them), but state() waits for the first
        # reset, reset_world or step, as every env's state() waits for its reset
        # (docs/interface.md, "Global state").
        self._started = False
        self._core_learners = core_learners
        #: :attr:`_learned_opponent_side`, kept here for :meth:`step`'s fast path (it changes
        #: only in :meth:`set_opponent`).
        self._learned_side: str | None = None
        #: The opponent side's observations of the current step ([E, K, D]), for its next action.
        self._opponent_obs: np.ndarray | None = None
        self.params: dict = self._core.params
        self.num_envs: int = self._core.num_envs
        self.n_wolves: int = self._core.n_wolves
        self.n_targets: int = self._core.n_targets
        self.wolf_obs_dim: int = self._core.wolf_obs_dim
        self.target_obs_dim: int = self._core.target_obs_dim
        #: Entries of one world's global state row (see :meth:`state`).
        self.state_dim: int = self._core.state_dim
        self._check_opponent_fits(self.opponent)
        self._learned_side = self._learned_opponent_side
        if self._learned_opponent_side is not None:
            # The worlds exist from construction on (a step before any reset is allowed).
            self._opponent_obs = self._split_opponent(self._core.observe())[1]

    # --- the opponent -------------------------------------------------------------------------

    @property
    def opponent_side(self) -> str | None:
        """The side a learned or named opponent drives (None without one)."""
        return opponent_side(self.opponent, self.learners) if self.opponent is not None else None

    def _check_opponent_fits(self, opponent: Opponent | None) -> None:
        if opponent is None or opponent.obs_dim is None:
            return
        side = opponent_side(opponent, self.learners)
        ours = self.wolf_obs_dim if side == "wolves" else self.target_obs_dim
        if not opponent.fits(ours):
            raise ObservationSizeError(
                f"opponent {opponent.name!r} takes {opponent.obs_dim} observations, but the {side} here have {ours} (other params, or an older observation layout)", opponent.obs_dim, ours
            )
        seen = opponent.entity_kinds
        if seen is not None:
            unseen = sorted(entity_kinds(side, self.params) - set(seen))
            if unseen:
                rows = " and ".join(unseen)
                raise ObservationSizeError(
                    f"opponent {opponent.name!r} never met {rows} rows in training, and the {side} here observe them: train it where they occur (--task)",
                    opponent.obs_dim,
                    ours,
                    f"it never met {rows} rows in training",
                )

    def set_opponent(self, opponent: Any) -> None:
        """Swaps what drives the non-learning side from the next step on, keeping every world
        as it is (for leagues: swap between rollouts). ``opponent`` as in the constructor; None
        goes back to the law of the params the batch was built with. A scripted law that takes
        over mid-episode starts its memory afresh at the current state."""
        new = as_opponent(opponent) if opponent is not None else None
        if new is not None:
            self._check_opponent_fits(new)
        core_learners, core_params = drivers(self._base_params, self.learners, new)
        self._core.set_drivers(core_learners, core_params)
        before = self._core_learners
        self._core_learners, self.opponent, self.params = core_learners, new, self._core.params
        self._learned_side = self._learned_opponent_side
        if self._learned_opponent_side is None:
            self._opponent_obs = None
        elif core_learners != before:  # its side was scripted until now: read its observations
            self._opponent_obs = self._split_opponent(self._core.observe())[1]

    @property
    def _learned_opponent_side(self) -> str | None:
        """The side a learned opponent drives from Python (None: none, or a law in the core)."""
        return self.opponent_side if self.opponent is not None and self.opponent.learned else None

    def _split_opponent(self, out: dict) -> tuple[dict, np.ndarray | None]:
        """A core output as (the user's outputs, the learned opponent's observations or None):
        the opponent side's observation arrays (current and final) are left out of a new dict,
        and ``out`` itself is not changed (it may be the caller's ``out=`` buffers)."""
        side = self._learned_opponent_side
        if side is None:
            return out, None
        hidden = (f"obs_{side}", f"final_obs_{side}")
        return {k: v for k, v in out.items() if k not in hidden}, out[f"obs_{side}"]

    def _opponent_actions(self) -> np.ndarray:
        """One batched call: the opponent's actions for all its agents in all worlds."""
        obs = self._opponent_obs
        e, k, d = obs.shape
        return self.opponent.act(obs.reshape(e * k, d)).reshape(e, k, 2)

    def __reduce__(self):
        # Constructor-argument pickling: the copy is a fresh batch built the same way.
        return (rebuild, (type(self), self._init_kwargs))

    @property
    def learns_wolves(self) -> bool:
        return self.learners in ("wolves", "both")

    @property
    def learns_targets(self) -> bool:
        return self.learners in ("targets", "both")

    def reset(self, seed: int | None = None) -> dict[str, np.ndarray]:
        """Resets every world; with ``seed``, world i is re-seeded ``seed + i`` (so ``seed +
        num_envs - 1`` must be < 2**64)."""
        out, self._opponent_obs = self._split_opponent(self._core.reset(check_seed(seed, span=self.num_envs, optional=True)))
        self._started = True
        return out

    def state(self) -> np.ndarray:
        """Every world's global state for centralised critics, float32 [E, state_dim], every
        entry in [−1, 1], fixed size for fixed params. Per row, in order: each wolf (x̂, ŷ,
        cos θ, sin θ, v/v_max, ω/ω_max), each target (the same, then 1 once its hunt ended,
        else 0), each of the params' K obstacle slots (1, x̂, ŷ, cos φ, sin φ — all 0 when a
        layout left the slot empty), and t / max_steps; x̂, ŷ map the arena onto [−1, 1]².
        ValueError when a layout put more obstacles in a world than the params count;
        RuntimeError before the first :meth:`reset`, :meth:`reset_world` or :meth:`step`."""
        if not self._started:
            raise RuntimeError("call reset() before state()")
        return self._core.state()

    def reset_world(self, index: int, seed: int | None = None, layout: Mapping[str, Any] | None = None) -> dict[str, np.ndarray]:
        """Resets world ``index`` alone (seeded ``seed`` itself), optionally from a LAYOUT."""
        index = check_index(index, self.num_envs)
        seed = check_seed(seed, optional=True)
        if layout is not None:
            check_tree(layout, "layout")
        out, fresh = self._split_opponent(self._core.reset_world(index, seed, layout))
        self._started = True
        if fresh is not None and self._opponent_obs is not None:
            self._opponent_obs[index] = fresh[index]
        elif fresh is not None:
            self._opponent_obs = fresh
        return out

    def new_outputs(self) -> dict[str, np.ndarray]:
        """Zeroed output arrays of this batch's shapes, keyed as :meth:`step` returns them: what
        ``step(out=...)`` writes into, step after step, without allocating. With a learned
        opponent they also hold its side's observations, which :meth:`step` writes (the
        opponent acts from them) and leaves out of what it returns."""
        return self._core.new_outputs()

    def step(self, wolf_actions: Any = None, target_actions: Any = None, *, out: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        """Steps every world. Actions [E, N, 2] / [E, M, 2] in [-1, 1] (clipped), for (and only
        for) the learning sides; float32 C-contiguous arrays go to the core as they are, other
        floating arrays are converted.

        Returns the outputs in new arrays, or, with ``out`` (from :meth:`new_outputs`), writes
        them into its arrays and returns a dict of them: no allocation, but each step
        overwrites the last, so copy what must outlive it. Nothing moves, and ``out`` is
        untouched, when the actions or ``out`` are wrong (ValueError naming them)."""
        self._started = True
        side = self._learned_side
        if side is None:
            return self._core.step(wolf_actions, target_actions, out)
        # A learned opponent acts from Python, from the observations of the last step.
        given, plural = (wolf_actions, "wolf") if side == "wolves" else (target_actions, "target")
        if given is not None:
            raise ValueError(f"{plural} actions given, but the {side} are not learners here")
        if side == "wolves":
            wolf_actions = self._opponent_actions()
        else:
            target_actions = self._opponent_actions()
        res, self._opponent_obs = self._split_opponent(self._core.step(wolf_actions, target_actions, out))
        return res

    def expert_actions(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The scripted laws' actions for the learning sides, in their action space."""
        wa, ta = self._core.expert_actions()
        return (wa if self.learns_wolves else None, ta if self.learns_targets else None)

    def world_state(self, index: int = 0) -> dict[str, Any]:
        """World ``index``'s full state (see ``WolfpackParallelEnv.world_state``)."""
        return self._core.world_state(check_index(index, self.num_envs))


def rebuild(cls, kwargs):
    """Unpickling for every wolfpack env: a fresh instance from its constructor arguments."""
    return cls(**kwargs)
