"""Argument checks shared by the Python API (BatchEnv, the env adapters, run_episodes).

Python's conventions: a TypeError for a wrong type (a str seed, a float count, a bool where a
number is meant), a ValueError for a value of the right type outside its range (a negative
seed, zero worlds, ``threads=100000``) and for a flag that is not True or False. Every message
names the argument.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from wolfpack import _core

#: Seeds are unsigned 64-bit integers: 0 <= seed < 2**64.
SEED_END = 2**64
#: The most worker threads a run may ask for: the core's bound, checked here first so that a
#: wrong type is a TypeError.
MAX_THREADS: int = _core.MAX_THREADS


def usable_cores() -> int:
    """Cores this process may use (its CPU affinity where the platform has one): what the core's
    thread pool and the trainer use by default."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def is_int(value: Any) -> bool:
    """An int or numpy integer, but not a bool (True is not a seed or a count)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def check_int(value: Any, name: str, lo: int, hi: int | None = None) -> int:
    """``value`` as an int in ``[lo, hi]`` (``hi`` None: no upper bound); TypeError if it is not
    an integer, ValueError if it is out of range."""
    if not is_int(value):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    value = int(value)
    if value < lo or (hi is not None and value > hi):
        bound = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise ValueError(f"{name} must be an integer {bound}, got {value}")
    return value


def check_seed(value: Any, name: str = "seed", *, span: int = 1, optional: bool = False) -> int | None:
    """A seed: an integer in [0, 2**64). ``span`` seeds are derived from it (``seed + i`` for
    i < span: one per world or per episode), so ``seed + span - 1`` must stay below 2**64 too.
    ``optional``: None passes through."""
    if value is None and optional:
        return None
    if not is_int(value):
        raise TypeError(f"{name} must be an integer in [0, 2**64){' or None' if optional else ''}, got {type(value).__name__} {value!r}")
    value = int(value)
    if not 0 <= value < SEED_END:
        raise ValueError(f"{name} must be an integer in [0, 2**64), got {value}")
    if value + span - 1 >= SEED_END:
        raise ValueError(f"{name}: the derived seeds {name} + i for i < {span} must be < 2**64, got {name} = {value}")
    return value


def check_flag(value: Any, name: str) -> bool:
    """True or False (numpy's bools too); ValueError for anything else ("no", 1, None)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def check_threads(value: Any, name: str = "threads") -> int | None:
    """None (all cores) or an integer in [1, :data:`MAX_THREADS`]."""
    if value is None:
        return None
    return check_int(value, name, 1, MAX_THREADS)


def check_index(value: Any, count: int, name: str = "world index") -> int:
    """An index in [0, count); TypeError if not an integer, ValueError if out of range."""
    if not is_int(value):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    value = int(value)
    if not 0 <= value < count:
        raise ValueError(f"{name} {value} out of range (num_envs = {count})")
    return value
