"""Type stubs for the native module ``wolfpack._core`` (rust/py/src/lib.rs)."""

from typing import Any

__version__: str

def default_params() -> dict[str, Any]:
    """The documented scenario's parameters (``capture.count`` null: derived as ⌈0.8 N⌉)."""

def validate_params(params: dict[str, Any] | None, resolve: bool = False) -> dict[str, Any]:
    """Validates a params dict and returns it complete; with ``resolve``, derived values
    (``capture.count``) are filled in. Raises ValueError naming the offending key."""

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
