"""Fuzzing every params key and layout field: any input either is refused with a
ValueError naming what is wrong, or gives a well-defined simulation — finite observations,
rewards, states and energies, every agent strictly inside the arena.

Values come from the core's own range table (``_core.param_limits()``, see
tests/param_strategies.py): inside the range (often at a bound), outside it, NaN/±inf, wrong
types, nesting. Agent and obstacle counts, episode length and spawn budgets are capped for the
simulated cases only, so that each example takes milliseconds; their full ranges are fuzzed by
the validation tests in test_config.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import wolfpack
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from param_strategies import LEAF_KEYS, invalid_value, valid_value
from test_config import fix_cross_field_rules
from wolfpack import _core

#: Caps for simulated examples: (key, most).
SIM_CAPS = {
    "world.wolves": 8,
    "world.targets": 3,
    "world.max_steps": 25,
    "obstacles.static_circles": 4,
    "obstacles.moving_circles": 4,
    "obstacles.static_polygons": 4,
    "obstacles.moving_polygons": 4,
    "world.spawn_attempts": 300,
    "world.spawn_restarts": 4,
    "env.lidar.rays": 64,
    "bvc.disc_sides": 64,
    "formation.ring_points": 16,
}
CHOICES = {
    "policies.wolves": ["seed000", "bvc", "formation"],
    "policies.targets": ["escape", "random", "still"],
    "env.action_mode": ["unicycle", "velocity"],
    "env.wolf_action_mode": [None, "unicycle", "velocity"],
    "env.target_action_mode": [None, "unicycle", "velocity"],
    "capture.rule": ["count", "encircle", "hunting_points"],
    "capture.cornered": [False, True],
    "world.feasibility_filter": [False, True],
    "agents.target.fatigue": [False, True],
    "env.interaction_row": [False, True],
}


def _capped(key: str, value):
    if key in SIM_CAPS:
        return min(value, SIM_CAPS[key])
    if key == "obstacles.polygon_vertices":
        return [min(v, 32) for v in value]
    return value


@st.composite
def scenarios(draw) -> dict:
    """Overrides: up to 10 numeric keys drawn in range, some categorical choices, and with
    probability 1/3 one key drawn outside its range."""
    keys = draw(st.sets(st.sampled_from(LEAF_KEYS), max_size=10))
    o = {k: _capped(k, draw(valid_value(k))) for k in sorted(keys)}
    for k in draw(st.sets(st.sampled_from(sorted(CHOICES)), max_size=4)):
        o[k] = draw(st.sampled_from(CHOICES[k]))
    o["world.max_steps"] = min(o.get("world.max_steps", 25), 25)
    o = fix_cross_field_rules(o)
    if draw(st.integers(0, 2)) == 0:
        bad = draw(st.sampled_from(LEAF_KEYS))
        o[bad] = draw(invalid_value(bad))
        o["_invalid"] = bad
    return o


def assert_finite(name: str, a) -> None:
    a = np.asarray(a, dtype=np.float64)
    assert np.isfinite(a).all(), f"{name} holds non-finite values"


def assert_inside(env, border) -> None:
    """Every agent of every world finite and strictly inside the arena, the state in [-1, 1]."""
    state = env.state()
    assert_finite("state", state)
    assert (np.abs(state) <= 1.0).all(), "state leaves [-1, 1]"
    for i in range(env.num_envs):
        w = env.world_state(i)
        for side in ("wolves", "targets"):
            assert_finite(side, w[side])
            pos = w[side][:, :2]
            inside = (pos[:, 0] > border[0]) & (pos[:, 0] < border[2]) & (pos[:, 1] > border[1]) & (pos[:, 1] < border[3])
            assert inside.all(), f"{side} left the arena {border}: {pos[~inside]}"
        assert_finite("energy", w["energy"])


def simulate(params: dict, seed: int, learners: str) -> None:
    env = _core.BatchEnv(params, 2, learners, seed, True, 1)
    n, m = env.n_wolves, env.n_targets
    rng = np.random.default_rng(seed)
    border = params["world"]["border"]
    env.reset(seed)
    for _ in range(30):  # past max_steps (<= 25): autoreset is exercised
        wa = rng.uniform(-1, 1, (2, n, 2)).astype(np.float32) if learners in ("wolves", "both") else None
        ta = rng.uniform(-1, 1, (2, m, 2)).astype(np.float32) if learners in ("targets", "both") else None
        out = env.step(wa, ta)
        for key, value in out.items():
            if np.asarray(value).dtype.kind == "f":
                assert_finite(key, value)
        assert_inside(env, border)
    for r in _core.run_episodes(params, seed, 0, 2, None, False, 1):
        assert_finite("episode energy", r["energy"])
        assert r["outcome"] in wolfpack.OUTCOMES


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios(), st.integers(0, 2**32), st.sampled_from(["wolves", "targets", "both", "none"]))
def test_every_key_is_refused_by_name_or_simulates_finitely_inside_the_arena(overrides, seed, learners):
    bad = overrides.pop("_invalid", None)
    try:
        params = wolfpack.load_params(overrides=overrides)
    except ValueError as e:
        msg = str(e)
        assert "\n" not in msg
        if bad is None:
            # Only the cross-field rules can refuse a drawn-in-range scenario; they name a key.
            assert any(k.split(".")[0] in msg for k in overrides), msg
        else:
            assert bad.split(".")[-1] in msg or bad.split(".")[0] in msg, f"{bad}: {msg}"
        return
    assert bad is None, f"{bad} = {overrides[bad]!r} was accepted"
    try:
        simulate(params, seed, learners)
    except ValueError as e:
        msg = str(e)
        # A crowded arena may not spawn; a law whose arithmetic overflows inside the ranges is
        # stopped with its name. Anything else is a bug.
        assert msg.startswith("spawn:") or " law produced a non-finite command" in msg, msg


# --- layouts ------------------------------------------------------------------------------

coordinate = st.one_of(st.floats(-12, 12, allow_nan=False), st.sampled_from([math.nan, math.inf, -math.inf, 1e308]))
pose = st.lists(coordinate, min_size=3, max_size=3)
odd = st.one_of(st.text(max_size=3), st.none(), st.just({"x": 1}), st.lists(st.integers(), max_size=4), st.just([[[[[1]]]]]))
circle = st.fixed_dictionaries(
    {
        "kind": st.just("circle"),
        "center": st.lists(coordinate, min_size=2, max_size=2),
        "radius": st.one_of(st.floats(-1, 3, allow_nan=False), st.sampled_from([0.0, math.nan, 1e39])),
        "moving": st.booleans(),
    }
)
polygon = st.fixed_dictionaries(
    {"kind": st.just("polygon"), "center": st.lists(coordinate, min_size=2, max_size=2), "vertices": st.lists(st.lists(coordinate, min_size=2, max_size=2), max_size=8), "moving": st.booleans()}
)


@st.composite
def layouts(draw) -> dict:
    layout = {
        "wolves": draw(st.lists(pose, min_size=0, max_size=6)),
        "targets": draw(st.lists(pose, min_size=0, max_size=3)),
        "obstacles": draw(st.lists(circle | polygon, max_size=5)),
    }
    if draw(st.integers(0, 4)) == 0:  # one field of a wrong type or shape
        field = draw(st.sampled_from(["wolves", "targets", "obstacles"]))
        layout[field] = draw(odd)
    return layout


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(layouts(), st.sampled_from(["seed000", "bvc", "formation"]))
def test_every_layout_is_refused_with_a_reason_or_simulates_finitely(layout, law):
    params = wolfpack.load_params(overrides={"policies.wolves": law, "world.max_steps": 20})
    try:
        resolved = _core.check_layout(params, layout)
    except ValueError as e:
        msg = str(e)
        assert msg.startswith("layout") and "\n" not in msg, msg
        return
    border = resolved["world"]["border"]
    for r in _core.run_episodes(params, 0, 0, 1, layout, True, 1):
        t = r["trajectory"]
        for side in ("wolves", "targets"):
            assert_finite(side, t[side])
            pos = t[side][..., :2]
            assert ((pos[..., 0] > border[0]) & (pos[..., 0] < border[2]) & (pos[..., 1] > border[1]) & (pos[..., 1] < border[3])).all()
        assert_finite("energy", t["energy"])


def test_the_documented_ranges_cover_every_numeric_key():
    """The range table and the params agree (the Rust side also fails on a missing entry)."""
    assert len(LEAF_KEYS) > 80
    with pytest.raises(ValueError, match=r"seed000\.tau1: must be in \[-10, 10\]"):
        wolfpack.load_params(overrides={"seed000.tau1": 300})


# --- the documented table -----------------------------------------------------------------

DOCS = __import__("pathlib").Path(__file__).resolve().parents[1] / "docs" / "world-and-laws.md"


def _num(x: float) -> str:
    for value, name in ((math.pi, "π"), (math.pi / 2, "π/2")):
        if x == value:
            return name
    if x != 0 and (abs(x) >= 1e4 or abs(x) < 1e-3):
        mantissa, exponent = f"{abs(x):e}".split("e")
        mantissa = mantissa.rstrip("0").rstrip(".")
        return ("−" if x < 0 else "") + ("" if mantissa == "1" else f"{mantissa}·") + f"10^{int(exponent)}"
    return f"{round(x, 6):g}".replace("-", "−")


def ranges_table() -> str:
    """The Markdown table of docs/world-and-laws.md "Parameter ranges", from the core's table."""
    rows = ["| key | allowed | unit / note |", "|---|---|---|"]
    for limit in _core.param_limits():
        lo = "(" if limit["open_lo"] else "["
        rows.append(f"| `{limit['key']}` | {lo}{_num(limit['lo'])}, {_num(limit['hi'])}] | {limit['unit']} |")
    return "\n".join(rows)


def test_the_docs_list_every_documented_range():
    table = ranges_table()
    assert table in DOCS.read_text(encoding="utf-8"), "docs/world-and-laws.md's range table is stale; it should read:\n" + table


if __name__ == "__main__":  # python tests/test_params_fuzz.py prints the table for the docs
    print(ranges_table())


def test_a_formation_clearance_wider_than_half_the_arena_simulates():
    """Found by the fuzz above: the slot clamp's range was empty (min > max) and the core
    panicked; the margin is now capped at half the arena."""
    params = wolfpack.load_params(overrides={"policies.wolves": "formation", "formation.clearance": 11.0, "world.max_steps": 25})
    simulate(params, 0, "targets")
