"""``wolfpack/Escape-v0`` and ``wolfpack/Escape-<task>``: one learning target against the
scripted wolves (Gymnasium).

The single-agent view of :mod:`wolfpack.parallel_env` with ``learners="targets"``: the same
target observation, action space, rewards, termination and infos (see that module's
docstring). The wolves follow ``policies.wolves`` (default ``seed000``), or ``opponent`` (a
law's name, a saved wolf model or a callable: :mod:`wolfpack.opponents`). Needs
``world.targets == 1``.

    import gymnasium, wolfpack
    env = gymnasium.make("wolfpack/Escape-v0")            # or ..., params="my.yaml", world__wolves=4
    env = gymnasium.make("wolfpack/Escape-fast-target-v1")  # a task of the benchmark suite

``wolfpack/Escape-v0`` plays ``params`` (default: the documented scenario, whatever the installed
version's defaults are); ``wolfpack/Escape-<task>`` plays a frozen task of the benchmark suite
(docs/tasks.md), one id for each task with one target (``task=`` of this class).

Arguments: ``params`` (None, YAML path or dict) or ``task`` (a task's name), ``render_mode`` (None, ``"rgb_array"`` or
``"human"``, as the ParallelEnv's), ``render_options`` (dict: width, height, trail, sensing,
links), ``seed`` (the base
seed when ``reset`` gets none), ``**overrides`` (``world__wolves=4`` or
``**{"world.wolves": 4}``). ``reset(options={"layout": LAYOUT})`` starts from an explicit
state. ``env.unwrapped.world_state()`` / ``env.unwrapped.expert_actions()`` as in the
ParallelEnv (the expert is the scripted escape law).

Version History: Escape-v0, first release; the task ids carry their task's version.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import gymnasium
import numpy as np

from wolfpack._checks import check_seed
from wolfpack.batch import BatchEnv, rebuild
from wolfpack.parallel_env import action_box, check_render_mode, check_render_options, observation_box
from wolfpack.render import RENDER_MODES, EnvRendering, FrameOptions
from wolfpack.views import agent_infos, check_action


class EscapeEnv(gymnasium.Env):
    """See the module docstring."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10}

    def __init__(
        self,
        params: str | Path | Mapping[str, Any] | None = None,
        *,
        task: str | None = None,
        render_mode: str | None = None,
        render_options: Mapping[str, Any] | None = None,
        seed: int = 0,
        opponent: Any = None,
        **overrides: Any,
    ) -> None:
        self._init_kwargs = dict(params=params, task=task, render_mode=render_mode, render_options=render_options, seed=seed, opponent=opponent, **overrides)
        self.render_mode = check_render_mode(render_mode, tuple(self.metadata["render_modes"]))
        frame_options = FrameOptions(**check_render_options(render_options))
        self._batch = BatchEnv(params, task=task, num_envs=1, learners="targets", seed=seed, autoreset=False, threads=1, opponent=opponent, **overrides)
        self._view = EnvRendering(self.render_mode, self._batch.params, frame_options, self.metadata["render_fps"])
        if self._batch.n_targets != 1:
            raise ValueError(f"this view has one learning target; world.targets is {self._batch.n_targets} (use wolfpack.parallel_env for several)")
        self.observation_space = observation_box(self._batch.target_obs_dim)
        self.action_space = action_box()
        self._seed = seed
        self._started = False
        self._done = False

    def __reduce__(self):
        return (rebuild, (type(self), self._init_kwargs))

    @property
    def params(self) -> dict:
        return self._batch.params

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        seed = check_seed(seed, optional=True)  # before Gymnasium's own check (its own error type)
        super().reset(seed=seed)
        layout = None
        if options is not None and not isinstance(options, Mapping):
            raise TypeError(f"options must be a dict, got {type(options).__name__}")
        if options:
            # Other keys are ignored, as Gymnasium and PettingZoo envs do with options they
            # do not know (PettingZoo's own API test passes one).
            layout = options.get("layout")
        if seed is None and not self._started:
            seed = self._seed
        out = self._batch.reset_world(0, seed, layout)
        self._started, self._done = True, False
        self._view.record(self.world_state)
        return out["obs_targets"][0, 0], self._info(out)

    def step(self, action: Any):
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if self._done:
            raise RuntimeError("the episode is over; call reset() to start a new one")
        # Shape and dtype here; a NaN or inf is refused by the core, naming target_0.
        a = check_action(action, "action")
        out = self._batch.step(None, a.reshape(1, 1, 2))
        self._view.record(self.world_state)
        terminated, truncated = bool(out["terminated"][0]), bool(out["truncated"][0])
        self._done = terminated or truncated
        return out["obs_targets"][0, 0], float(out["rewards_targets"][0, 0]), terminated, truncated, self._info(out)

    def _info(self, out: dict) -> dict:
        n = self._batch.n_wolves
        return agent_infos(out, n, n, n + 1)[0]

    def world_state(self) -> dict[str, Any]:
        """The world's state (see ``WolfpackParallelEnv.world_state``)."""
        return self._batch.world_state(0)

    def expert_actions(self) -> np.ndarray:
        """The scripted target law's action now (float32, shape (2,))."""
        return self._batch.expert_actions()[1][0, 0].copy()

    def render(self):
        """``rgb_array``: the current frame, uint8 [H, W, 3]; ``human``: shown in a window."""
        return self._view.render()

    def close(self) -> None:
        self._view.close()
