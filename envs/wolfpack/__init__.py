"""wolfpack: multi-agent pursuit–evasion (wolf-pack hunting) with a Rust core.

Public entry points (see API.md in the project docs):

- :func:`load_params` — read and validate a scenario (``params.yaml`` plus dotted overrides).
- :func:`run_episodes` — run scripted episodes in parallel (the engine behind ``wolfpack hunt``).
- ``wolfpack`` command line: ``wolfpack hunt --help``.
"""

from wolfpack._core import __version__
from wolfpack.config import DEFAULT_PARAMS_PATH, load_params, load_layout
from wolfpack.episodes import run_episodes, summarize

__all__ = [
    "__version__",
    "DEFAULT_PARAMS_PATH",
    "load_params",
    "load_layout",
    "run_episodes",
    "summarize",
]
