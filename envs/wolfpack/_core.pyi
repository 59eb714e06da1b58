"""Type stubs for the native module ``wolfpack._core`` (rust/py/src/lib.rs)."""

from typing import Any, Mapping

import numpy as np
from numpy.typing import NDArray

__version__: str
#: The most threads a pool may have (``wolfpack_core::episode::MAX_THREADS``).
MAX_THREADS: int
#: The outcomes in the order of their codes (a batch's ``outcome`` array indexes it).
OUTCOMES: tuple[str, ...]
#: The scripted laws of each side, as ``policies.wolves`` / ``policies.targets`` take them.
WOLF_LAWS: tuple[str, ...]
TARGET_LAWS: tuple[str, ...]
#: The laws' modes, indexed by the codes of a trajectory's ``wolf_mode`` / ``target_mode``
#: (``wolfpack_core::world::LawMode``; 0 is ``none``: no law drove the agent).
LAW_MODES: tuple[str, ...]
#: The values of ``learners=``.
LEARNERS: tuple[str, ...]
#: The renderer's RGB colours (``wolfpack_core::render``).
WOLF_COLOURS: tuple[tuple[int, int, int], ...]
TARGET_COLOUR: tuple[int, int, int]
STATIC_OBSTACLE_COLOUR: tuple[int, int, int]
MOVING_OBSTACLE_COLOUR: tuple[int, int, int]

def default_params() -> dict[str, Any]:
    """The documented scenario's parameters (``capture.count`` null: derived as ⌈0.8 N⌉)."""

def validate_params(params: dict[str, Any] | None, resolve: bool = False) -> dict[str, Any]:
    """Validates a params dict and returns it complete; with ``resolve``, derived values
    (``capture.count``) are filled in. Raises ValueError naming the offending key."""

def observation_layout(params: Mapping[str, Any], side: str) -> list[dict[str, Any]]: ...
def param_limits() -> list[dict[str, Any]]:
    """The documented range of every numeric parameter: dicts ``{key, lo, hi, open_lo, unit}``
    (``lo`` excluded when ``open_lo``); array elements share their array's key and a table key
    (``avoidance.wolf_single``) covers each of its fields."""

def check_layout(params: dict[str, Any] | None, layout: dict[str, Any], seed: int = 0) -> dict[str, Any]:
    """Builds the world a layout describes (raising ValueError if it is malformed or
    infeasible) and returns the resolved params it implies (agent counts from the layout)."""

def run_episodes(
    params: dict[str, Any] | None,
    seed: int,
    first: int = 0,
    count: int = 1,
    layout: dict[str, Any] | None = None,
    record: bool = False,
    threads: int | None = None,
) -> list[dict[str, Any]]:
    """Runs scripted episodes ``first .. first+count`` (seed ``seed + k``) in parallel with the
    GIL released; one result dict per episode, in order."""

def render_frame(scene: dict[str, Any], width: int, height: int) -> NDArray[np.uint8]:
    """Draws a scene dict (built by :mod:`wolfpack.render`) into a new (height, width, 3) uint8
    RGB array with the GIL released; ValueError on a malformed scene or a size outside 16..4096."""

class BatchEnv:
    """The native batch (private; see ``wolfpack.BatchEnv``): ``num_envs`` worlds stepped
    together with the GIL released."""

    num_envs: int
    n_wolves: int
    n_targets: int
    wolf_obs_dim: int
    target_obs_dim: int
    state_dim: int
    params: dict[str, Any]

    def __init__(
        self,
        params: dict[str, Any] | None = None,
        num_envs: int = 1,
        learners: str = "wolves",
        seed: int = 0,
        autoreset: bool = True,
        threads: int | None = None,
        with_state: bool = False,
    ) -> None: ...
    def reset(self, seed: int | None = None) -> dict[str, Any]:
        """Resets every world (world i seeded ``seed + i``, else its next episode)."""
    def reset_world(self, index: int, seed: int | None = None, layout: dict[str, Any] | None = None) -> dict[str, Any]:
        """Resets one world, optionally seeded and from a LAYOUT."""
    def new_outputs(self) -> dict[str, Any]:
        """Zeroed output arrays of this batch's shapes (the keys ``step`` returns)."""
    def step(self, wolf_actions: Any = None, target_actions: Any = None, out: dict[str, Any] | None = None) -> dict[str, Any]:
        """The one step call: actions [E, N, 2] / [E, M, 2] for the learning sides (float32
        C-contiguous used as is, other floating arrays converted); outputs written into
        ``out`` (from ``new_outputs``) and returned, or into a new dict."""
    def expert_actions(self) -> tuple[Any, Any]:
        """The scripted laws' actions for the learning sides (None for the others)."""
    def observe(self) -> dict[str, Any]:
        """The current observations and infos of every world (nothing moves, no rewards)."""
    def set_drivers(self, learners: str, params: dict[str, Any]) -> None:
        """Who drives each side from the next step on; params may differ only in policies.*
        and env.*action_mode. Every world is kept."""
    def state(self) -> Any:
        """Every world's global state, float32 [num_envs, state_dim]."""
    def world_state(self, index: int) -> dict[str, Any]:
        """World ``index``'s state as numpy arrays and lists."""
