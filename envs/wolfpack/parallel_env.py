"""wolfpack as a PettingZoo ``ParallelEnv``: wolves hunt targets among moving obstacles.

This docstring is the environment's specification.

Agents
    ``wolf_0 … wolf_{N-1}`` and ``target_0 … target_{M-1}``; only the learning side's agents
    (``learners``) are PettingZoo agents, the other side follows its scripted law inside the
    core (``policies.wolves``: ``seed000``, ``bvc`` or ``formation``; ``policies.targets``:
    ``escape``, ``random``, ``still``; the laws: docs/world-and-laws.md §3–§7). Defaults (``params.yaml``): 5 wolves, 1 target, 12 obstacles, 20 m × 20 m arena,
    Ts = 0.1 s, 300 steps.

Action Space
    ``Box(-1, 1, (2,), float32)`` per agent; values outside [-1, 1] are clipped, NaN/inf raise
    ``ValueError``. ``env.action_mode: unicycle`` (default): ``v = (a₀+1)/2 · v_max``,
    ``ω = a₁ · ω_max``. ``velocity``: ``a`` is a desired velocity in the agent's frame (x ahead,
    y left) in units of v_max, norm capped at 1, turned into (v, ω) by the saturator of world-and-laws §2
    exactly as the analytic laws are. Every move then passes the world's feasibility filter, and
    a target's speed is capped by the fatigue curve from its first sighting on.

Observation Space
    ``Box(-1.5, 1.5, (D,), float32)``, egocentric: relative positions in the agent's frame
    (x ahead, y left), relative headings as sin/cos of (other θ − own θ). N wolves, M targets,
    K = ``env.lidar.rays``; S = the longer arena side; r = the observer's sensing radius (3 m).

    ==========================  ===========================================================
    entries                     meaning
    ==========================  ===========================================================
    0                           own speed / v_max
    1                           own turn rate / ω_max
    2, 3                        sin θ, cos θ (own heading, world frame)
    4–7                         (x − x_min)/W, (x_max − x)/W, (y − y_min)/H, (y_max − y)/H
    8                           step / max_steps
    **wolf** 9 … 9+5M−1         per target (index order): sensed, dx/r, dy/r, sin Δθ, cos Δθ —
                                all zero unless this wolf senses it now (distance ≤ r)
    **wolf** next 5(N−1)        other wolves, nearest first: senses, dx/S, dy/S, sin Δθ,
                                cos Δθ (wolves communicate globally); senses = 1 when that
                                wolf has a target within its sensing radius now (a seed000
                                wolf that sees no target follows the nearest such partner)
    **target** 9                speed cap / v_max (the fatigue curve; 1 before any sighting)
    **target** 10 … 10+5N−1     wolves, nearest first: in range, dx/r, dy/r, sin Δθ, cos Δθ —
                                zero for wolves beyond r (masked)
    next K                      lidar: ray k at θ + 2πk/K, distance to the first obstacle or
                                wall / ``env.lidar.range`` (1 = nothing within range);
                                ``env.lidar.noise`` σ > 0 adds N(0, σ²), clipped to [0, 1]
    **wolf** next 4M (optional) ``env.last_sighting``: per target, the pack's latest sighting:
                                sighted, dx/S, dy/S (where the target stood the last time
                                any wolf sensed it, in this wolf's frame), age / max_steps;
                                all zero before the first sighting
    last N+M (optional)         ``env.interaction_row``: own row of the last step's
                                interaction matrix (0/1)
    ==========================  ===========================================================

    Defaults: D = 50 for a wolf, 51 for a target.

    ``shared_space=True`` (with ``learners="both"`` only) gives every agent one observation
    space, so that one shared policy can drive both sides (SuperSuit, Tianshou, RLlib's shared
    policies): D = 2 + (N+M) + max(Dw, Dt) — entry 0 is 1 for a wolf, entry 1 is 1 for a
    target, then a one-hot agent index over the N+M agents (wolves first), then the agent's own
    observation above, zero-padded (59 entries by default). Actions and rewards are unchanged.

Rewards (``rewards.*`` in params, per agent and step)
    Wolves: ``−time_penalty`` (0.01); ``+capture_bonus`` (10) to every wolf for each target
    captured this step; ``−collision_penalty`` (10) when its body overlaps an obstacle or a
    wolf; shaping ``shaping · (Φ(s') − Φ(s))`` (1.0) with ``Φ = −|d − r_h|``, d the distance to
    the nearest uncaptured target and r_h = 0.65 the hunting radius, Φ = 0 at a capture or
    collision (potential-based: the optimal policies are unchanged).
    Targets: ``+survival`` (0.1) per step uncaptured; ``−capture_penalty`` (10) when captured;
    ``−collision_penalty`` (10) at each step its body overlaps an obstacle (with the feasibility
    filter on, only a moving obstacle can do that); 0 once captured.

Termination / Truncation
    Terminated when every target is captured (success) or a wolf collides (failure);
    truncated at ``world.max_steps``. With ``capture.cornered: true`` a cornered target (
    world-and-laws §1.7: within ``capture.distance`` of a wall, 2+ wolves within it, inside the hull of those
    wolves and its closest wall points) ends like a captured one — rewards included — and an
    episode whose targets all ended, one of them cornered, ends as ``cornered``. A captured
    target leaves ``agents`` at once (with M > 1 the others play on). ``infos[agent]``, every
    value a number of one type for the whole episode (so Gymnasium's vector envs and TorchRL
    can stack them): ``outcome`` (int code: 0 running, 1 captured, 2 collision, 3 timeout, 4
    cornered — ``wolfpack.OUTCOMES[code]`` is the name), ``capture_step`` (int; target: its
    own; wolf: the episode's on success; −1 until then), ``cornered_step`` (int, the first step
    at which a target of the world was cornered, −1 if none ever was), ``energy``
    (Σ ½ m v² so far), ``collisions`` (steps in contact), ``distance`` (wolf: to the nearest
    uncaptured target, −1 when none is left; target: to the nearest wolf).

Arguments
    ``parallel_env(params=None, *, task=None, learners="wolves", render_mode=None, render_options=None, seed=0, shared_space=False, opponent=None, **overrides)``:
    ``opponent`` drives the side that does not learn: a scripted law's name, a saved SB3 model
    (path or object), any batched callable ``obs [n, D] -> actions [n, 2]``, or a
    ``wolfpack.Opponent`` (:mod:`wolfpack.opponents`); ``env.unwrapped.set_opponent(...)``
    swaps it between episodes or mid-episode.
    ``params`` is None (the documented scenario), a YAML path or a dict; ``task`` names a task
    of the benchmark suite instead (``wolfpack.tasks()``, docs/tasks.md; a ValueError lists the
    known ones); overrides, on top of either, are dotted
    keys (``**{"world.wolves": 8}``) or ``world__wolves=8``, and ``max_cycles`` is PettingZoo's
    name for ``world.max_steps``; a keyword that names no params key is a TypeError, a bad value
    a ValueError naming the key; a seed must be an integer in [0, 2**64) (a ValueError
    otherwise, a TypeError for a str, float or bool), flags True or False (ValueError).
    ``reset(seed=None, options=None)``;
    ``options={"layout": LAYOUT}`` starts from an explicit state (the layout format of docs/interface.md; example:
    examples/layout.json) with this env's agent
    counts (a polygon with ``"moving": false`` still rotates in place, as world-and-laws §1.3's static
    polygons do; it does not translate). ``env.unwrapped.world_state()`` and
    ``env.unwrapped.expert_actions()`` (below).

Rendering
    ``render_mode``: None, ``"rgb_array"`` (``render()`` returns the current frame, uint8
    [H, W, 3], drawn in Rust without any display server) or ``"human"`` (a matplotlib window;
    without a display a warning and nothing shown). ``render_options``: ``width``, ``height``
    (pixels, default 512), ``trail`` (steps, default 40), ``sensing`` (sensing circles),
    ``links`` (interaction links); what a frame shows: :mod:`wolfpack.render`.

Version History
    v0: first release.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from wolfpack.batch import BatchEnv, rebuild
from wolfpack.render import RENDER_MODES, EnvRendering, FrameOptions
from wolfpack.views import SharedObservation, agent_infos, check_action, check_shared_space


def action_box() -> spaces.Box:
    """A new action space (each agent and env gets its own, so that seeding one space's
    sampler does not reseed another's)."""
    return spaces.Box(-1.0, 1.0, (2,), np.float32)


#: Every observation entry lies within ±OBS_BOUND (the largest are the other wolves' offsets,
#: at most the arena's diagonal over its longer side, √2).
OBS_BOUND = 1.5


def observation_box(dim: int) -> spaces.Box:
    return spaces.Box(-OBS_BOUND, OBS_BOUND, (dim,), np.float32)


def check_render_options(options: Mapping[str, Any] | None) -> dict:
    """``render_options`` as FrameOptions keywords; ValueError naming an unknown key, TypeError
    if it is not a mapping."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise TypeError(f"render_options must be a dict, got {type(options).__name__}")
    known = ("width", "height", "trail", "sensing", "links")
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise ValueError(f"render_options: unknown key(s) {', '.join(map(repr, unknown))}; known: {', '.join(known)}")
    return dict(options)


def check_render_mode(render_mode: str | None, allowed: tuple[str, ...]) -> str | None:
    if render_mode is not None and render_mode not in allowed:
        raise ValueError(f"render_mode must be None{''.join(', ' + repr(m) for m in allowed)}, got {render_mode!r}")
    return render_mode


class WolfpackParallelEnv(ParallelEnv):
    """See the module docstring. Build it with :func:`wolfpack.parallel_env`."""

    metadata = {"name": "wolfpack_v0", "render_modes": RENDER_MODES, "is_parallelizable": True, "render_fps": 10}

    def __init__(
        self,
        params: str | Path | Mapping[str, Any] | None = None,
        *,
        task: str | None = None,
        learners: str = "wolves",
        render_mode: str | None = None,
        render_options: Mapping[str, Any] | None = None,
        seed: int = 0,
        shared_space: bool = False,
        opponent: Any = None,
        **overrides: Any,
    ) -> None:
        self._init_kwargs = dict(
            params=params, task=task, learners=learners, render_mode=render_mode, render_options=render_options, seed=seed, shared_space=shared_space, opponent=opponent, **overrides
        )
        self.shared_space = check_shared_space(shared_space, learners)
        self.render_mode = check_render_mode(render_mode, tuple(self.metadata["render_modes"]))
        frame_options = FrameOptions(**check_render_options(render_options))
        self._batch = BatchEnv(params, task=task, num_envs=1, learners=learners, seed=seed, autoreset=False, threads=1, opponent=opponent, **overrides)
        self._view = EnvRendering(self.render_mode, self._batch.params, frame_options, self.metadata["render_fps"])
        self.learners = self._batch.learners
        n, m = self._batch.n_wolves, self._batch.n_targets
        self._wolves = [f"wolf_{i}" for i in range(n)] if self._batch.learns_wolves else []
        self._targets = [f"target_{j}" for j in range(m)] if self._batch.learns_targets else []
        self.possible_agents = self._wolves + self._targets
        self.agents: list[str] = []
        self._shared = SharedObservation(n, m, self._batch.wolf_obs_dim, self._batch.target_obs_dim) if self.shared_space else None
        if self._shared is not None:
            self._obs_spaces = {a: observation_box(self._shared.dim) for a in self.possible_agents}
        else:
            self._obs_spaces = {a: observation_box(self._batch.wolf_obs_dim) for a in self._wolves}
            self._obs_spaces.update({a: observation_box(self._batch.target_obs_dim) for a in self._targets})
        self._act_spaces = {a: action_box() for a in self.possible_agents}
        #: The space of :meth:`state` (PettingZoo's ``state_space``).
        self.state_space = spaces.Box(-1.0, 1.0, (self._batch.state_dim,), np.float32)
        # agent name -> (is a wolf, index on its side)
        self._index = {a: (a.startswith("wolf"), int(a.rsplit("_", 1)[1])) for a in self.possible_agents}
        self._seed = seed
        self._started = False

    def __reduce__(self):
        return (rebuild, (type(self), self._init_kwargs))

    @property
    def params(self) -> dict:
        """The resolved params in force."""
        return self._batch.params

    def observation_space(self, agent: str) -> spaces.Box:
        return self._obs_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self._act_spaces[agent]

    def reset(self, seed: int | None = None, options: dict | None = None):
        layout = None
        if options is not None:
            if not isinstance(options, Mapping):
                raise TypeError(f"options must be a dict, got {type(options).__name__}")
            # Other keys are ignored, as Gymnasium and PettingZoo envs do with options they
            # do not know (PettingZoo's own API test passes one).
            layout = options.get("layout")
        if seed is None and not self._started:
            seed = self._seed
        out = self._batch.reset_world(0, seed, layout)
        self._started = True
        self.agents = list(self.possible_agents)
        self._captured = np.zeros(self._batch.n_targets, dtype=bool)
        self._view.record(self.world_state)
        return self._observations(out), self._infos(out, self.agents)

    def step(self, actions: Mapping[str, Any]):
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if not self.agents and self.possible_agents:
            raise RuntimeError("the episode is over (every agent is done); call reset() to start a new one")
        if not isinstance(actions, Mapping):
            raise ValueError(f"actions must be a dict agent -> action, got {type(actions).__name__}")
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"missing actions for {', '.join(missing)}")
        unknown = [a for a in actions if a not in self.agents]
        if unknown:
            raise ValueError(f"actions for agents that are not active: {', '.join(map(str, unknown))} (active: {', '.join(self.agents)})")
        n, m = self._batch.n_wolves, self._batch.n_targets
        wa = np.zeros((1, n, 2), np.float32) if self._wolves else None
        ta = np.zeros((1, m, 2), np.float32) if self._targets else None
        for agent, a in actions.items():
            is_wolf, idx = self._index[agent]
            (wa if is_wolf else ta)[0, idx] = check_action(a, f"action of {agent}")
        # One finiteness check over everything (per agent only to name the culprit); a float64
        # value beyond float32's range has become inf above and is caught here too.
        for buf in (wa, ta):
            if buf is not None and not np.isfinite(buf).all():
                bad = next(a for a in self.agents if not np.isfinite(np.asarray(actions[a], np.float32)).all())
                raise ValueError(f"action of {bad} is not finite: {np.asarray(actions[bad]).tolist()}")
        out = self._batch.step(wa, ta)
        self._view.record(self.world_state)
        terminated_world, truncated_world = bool(out["terminated"][0]), bool(out["truncated"][0])
        captured = out["capture_step"][0] >= 0
        obs = self._observations(out)
        rw = out["rewards_wolves"][0].tolist() if self._wolves else None
        rt = out["rewards_targets"][0].tolist() if self._targets else None
        rewards, terminations, truncations = {}, {}, {}
        for a in self.agents:
            is_wolf, idx = self._index[a]
            rewards[a] = rw[idx] if is_wolf else rt[idx]
            terminations[a] = terminated_world or (not is_wolf and bool(captured[idx]))
            truncations[a] = truncated_world and not terminations[a]
        infos = self._infos(out, self.agents)
        done_world = terminated_world or truncated_world
        self.agents = [] if done_world else [a for a in self.agents if not terminations[a]]
        return obs, rewards, terminations, truncations, infos

    def _observations(self, out: dict) -> dict[str, np.ndarray]:
        obs = {}
        active = set(self.agents) if self.agents else set(self.possible_agents)
        if self._shared is not None:
            packed = self._shared.pack(out["obs_wolves"], out["obs_targets"])[0]
            return {a: packed[k] for k, a in enumerate(self.possible_agents) if a in active}
        for i, a in enumerate(self._wolves):
            if a in active:
                obs[a] = out["obs_wolves"][0, i]
        for j, a in enumerate(self._targets):
            if a in active:
                obs[a] = out["obs_targets"][0, j]
        return obs

    def _infos(self, out: dict, agents: list[str]) -> dict[str, dict]:
        n = self._batch.n_wolves
        every = agent_infos(out, n, 0, n + self._batch.n_targets)
        infos = {}
        for a in agents:
            is_wolf, idx = self._index[a]
            infos[a] = every[idx if is_wolf else n + idx]
        return infos

    def world_state(self) -> dict[str, Any]:
        """The world's state: ``wolves`` [N, 5] and ``targets`` [M, 5] (x, y, θ, v, ω),
        ``energy`` [N+M], ``interaction`` [(N+M), (N+M)] uint8, ``obstacles`` (list of dicts:
        kind, moving, center, radius, angle, vertices [k, 2] in world coordinates), ``step``,
        plus ``captured``, ``outcome``, ``seed``, ``episode``."""
        return self._batch.world_state(0)

    @property
    def opponent(self):
        """What drives the side that does not learn (a :class:`wolfpack.Opponent`, or None:
        its law in params)."""
        return self._batch.opponent

    def set_opponent(self, opponent: Any) -> None:
        """Swaps the non-learning side's driver from the next step on, keeping the world
        (:meth:`wolfpack.BatchEnv.set_opponent`)."""
        self._batch.set_opponent(opponent)

    def expert_actions(self) -> dict[str, np.ndarray]:
        """What the scripted law of each active agent's side would do now, as an action in this
        env's action space (float32, shape (2,)). Following these actions reproduces the
        scripted episode (to float32 rounding of the actions)."""
        wa, ta = self._batch.expert_actions()
        acts = {}
        for a in self.agents:
            is_wolf, idx = self._index[a]
            acts[a] = (wa if is_wolf else ta)[0, idx].copy()
        return acts

    def state(self) -> np.ndarray:
        """The global state for a centralised critic (CTDE, MAPPO): float32 [state_dim] in
        ``state_space`` — every agent's pose and speed, the targets' ended flags, the
        obstacles' poses and the clock (layout: :meth:`wolfpack.BatchEnv.state`). A
        RuntimeError before ``reset()``."""
        if not self._started:
            raise RuntimeError("call reset() before state()")
        return self._batch.state()[0]

    def render(self):
        """``rgb_array``: the current frame, uint8 [H, W, 3] (see :mod:`wolfpack.render`);
        ``human``: shows it in a window and returns None; no render mode: None."""
        return self._view.render()

    def close(self) -> None:
        self._view.close()


def parallel_env(
    params: str | Path | Mapping[str, Any] | None = None,
    *,
    task: str | None = None,
    learners: str = "wolves",
    render_mode: str | None = None,
    render_options: Mapping[str, Any] | None = None,
    seed: int = 0,
    shared_space: bool = False,
    opponent: Any = None,
    **overrides: Any,
) -> WolfpackParallelEnv:
    """A PettingZoo ``ParallelEnv`` of one world (see this module's docstring)."""
    return WolfpackParallelEnv(params, task=task, learners=learners, render_mode=render_mode, render_options=render_options, seed=seed, shared_space=shared_space, opponent=opponent, **overrides)


# ``wolfpack.parallel_env`` (this function) hides the module of the same name in the package:
# give it the module's docstring, so that help(wolfpack.parallel_env) shows the specification.
parallel_env.__doc__ = f"{parallel_env.__doc__}\n\n{__doc__}"


def env(
    params: str | Path | Mapping[str, Any] | None = None,
    *,
    task: str | None = None,
    learners: str = "wolves",
    render_mode: str | None = None,
    render_options: Mapping[str, Any] | None = None,
    seed: int = 0,
    shared_space: bool = False,
    opponent: Any = None,
    **overrides: Any,
):
    """The same world as a PettingZoo ``AECEnv`` (agents act in turn; the world steps once all
    active agents have acted): PettingZoo's ``parallel_to_aec`` over :func:`parallel_env`, with
    the same arguments, spaces, ``state()`` and ``state_space``."""
    from pettingzoo.utils.conversions import parallel_to_aec

    par = parallel_env(params, task=task, learners=learners, render_mode=render_mode, render_options=render_options, seed=seed, shared_space=shared_space, opponent=opponent, **overrides)
    aec = parallel_to_aec(par)
    aec.state_space = par.state_space  # the converter forwards state() but not its space
    return aec
