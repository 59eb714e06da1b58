"""Optional dependencies: a missing one is an ImportError that says which extra brings it.

The core install (numpy, gymnasium, pettingzoo, PyYAML, matplotlib, imageio) steps, renders and
logs; learning needs the ``[train]`` extra (stable-baselines3, which brings torch)."""

from __future__ import annotations

import importlib
from types import ModuleType

#: The pip distribution that provides each optional module, and the extra that installs it.
PROVIDERS = {"stable_baselines3": ("stable-baselines3", "train"), "torch": ("torch", "train"), "minari": ("minari", "dataset"), "torchrl": ("torchrl", "torchrl"), "ray": ("ray", "rllib")}


def require(module: str, what: str) -> ModuleType:
    """``module`` imported, or an ImportError naming ``what`` needs it and the extra to install."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        if e.name is not None and e.name.split(".")[0] != module.split(".")[0]:
            raise  # the module is there but something it imports is broken: say that, not this
        dist, extra = PROVIDERS[module.split(".")[0]]
        raise ImportError(f"{what} needs {dist}, which is not installed: pip install 'wolfpack[{extra}]'", name=module) from None
