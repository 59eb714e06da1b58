"""Hypothesis strategies over every numeric params key, driven by the core's own range table
(``_core.param_limits()``), so that a key added to the table is fuzzed without editing tests.

``valid_value(key)`` draws inside the documented range (often exactly at a bound);
``invalid_value(key)`` draws what must be refused: just outside, NaN/±inf, huge, wrong types,
deep nesting.
"""

from __future__ import annotations

import math

from hypothesis import strategies as st
from wolfpack import _core

DEFAULTS = _core.default_params()
LIMITS = {limit["key"]: limit for limit in _core.param_limits()}


def default_of(key: str):
    node = DEFAULTS
    for part in key.split("."):
        node = node[part]
    return node


def leaf_keys() -> list[str]:
    """Every numeric key as a dotted path to a scalar or an array (a table key such as
    ``avoidance.wolf_single`` expands into its fields)."""
    keys = []
    for key in LIMITS:
        d = default_of(key)
        if isinstance(d, dict):
            keys += [f"{key}.{f}" for f in d]
        else:
            keys.append(key)
    return sorted(keys)


LEAF_KEYS = leaf_keys()


def limit_of(key: str) -> dict:
    while key not in LIMITS:
        key = key.rsplit(".", 1)[0]
    return LIMITS[key]


def is_integer(key: str) -> bool:
    d = default_of(key)
    d = d[0] if isinstance(d, (list, tuple)) else d
    # capture.count is the one numeric key whose default is null (derived); it is an integer.
    return d is None or (isinstance(d, int) and not isinstance(d, bool))


def _scalar_in(key: str, lo: float | None = None, hi: float | None = None) -> st.SearchStrategy:
    lim = limit_of(key)
    lo = lim["lo"] if lo is None else lo
    hi = lim["hi"] if hi is None else hi
    if is_integer(key):
        first = math.floor(lo) + 1 if lim["open_lo"] and float(lo).is_integer() else math.ceil(lo)
        return st.integers(first, int(hi)) | st.sampled_from([first, int(hi)])
    inner = st.floats(lo, hi, exclude_min=lim["open_lo"], allow_nan=False, allow_infinity=False)
    edges = [hi] if lim["open_lo"] else [lo, hi]
    return inner | st.sampled_from(edges)


def valid_value(key: str) -> st.SearchStrategy:
    d = default_of(key)
    if key == "world.border":
        # Each coordinate in range, width and height in [1, 1e4] as the validator computes them
        # (x_max − x_min in floating point: x_min + 1 − x_min can round to 0.9999999999999998).
        return (
            st.tuples(st.floats(-1e4, 9e3), st.floats(-1e4, 9e3), st.floats(1, 1e3), st.floats(1, 1e3))
            .map(lambda t: [t[0], t[1], min(t[0] + t[2], 1e4), min(t[1] + t[3], 1e4)])
            .filter(lambda b: 1 <= b[2] - b[0] <= 1e4 and 1 <= b[3] - b[1] <= 1e4)
        )
    if isinstance(d, (list, tuple)):  # an ordered [lo, hi] pair
        return st.lists(_scalar_in(key), min_size=2, max_size=2).map(sorted)
    return _scalar_in(key)


def invalid_value(key: str) -> st.SearchStrategy:
    """A value the validator must refuse, naming ``key``."""
    lim = limit_of(key)
    lo, hi = lim["lo"], lim["hi"]
    integer = is_integer(key)
    below = (
        st.integers(-(2**40), math.ceil(lo) - (0 if lim["open_lo"] and float(lo).is_integer() else 1))
        if integer
        else st.floats(-1e308, lo, exclude_max=not lim["open_lo"], allow_nan=False, allow_infinity=False)
    )
    above = st.integers(int(hi) + 1, 2**62) if integer else st.floats(hi, 1e308, exclude_min=True, allow_nan=False, allow_infinity=False)
    special = st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308])
    wrong_type = st.one_of(st.text(max_size=4), st.just({"deep": {"er": 1}}), st.just([[[1]]]))
    scalar = st.one_of(below, above, special, wrong_type)
    if isinstance(default_of(key), (list, tuple)):
        n = len(default_of(key))
        return st.one_of(wrong_type, scalar.map(lambda x: [x] * n))
    return scalar
