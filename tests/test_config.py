"""Scenario parameters: one source of truth (Rust defaults = params.yaml), dotted overrides, and
every kind of bad input rejected with a ValueError that names the key."""

from __future__ import annotations

import json
import math

import pytest
import wolfpack
import yaml
from conftest import REPO_ROOT, layout_dict
from hypothesis import given, settings
from hypothesis import strategies as st
from param_strategies import LEAF_KEYS, default_of, invalid_value, valid_value
from wolfpack import _core
from wolfpack.config import DEFAULT_PARAMS_PATH, apply_overrides, load_layout, load_params, parse_override

# --- one source of truth ------------------------------------------------------------------


def _plain(data):
    """JSON round trip: the core returns fixed-size arrays as tuples, YAML gives lists."""
    return json.loads(json.dumps(data))


def test_repository_and_packaged_params_yaml_are_the_same_document():
    assert yaml.safe_load((REPO_ROOT / "params.yaml").read_text()) == yaml.safe_load(DEFAULT_PARAMS_PATH.read_text())


class _UniqueKeyLoader(yaml.SafeLoader):
    """A SafeLoader that refuses a mapping with a key twice (PyYAML keeps the last silently)."""

    def construct_mapping(self, node, deep=False):
        keys = [self.construct_object(k, deep=deep) for k, _ in node.value]
        twice = sorted({k for k in keys if keys.count(k) > 1})
        if twice:
            raise yaml.constructor.ConstructorError(None, None, f"duplicate keys {twice}", node.start_mark)
        return super().construct_mapping(node, deep=deep)


@pytest.mark.parametrize("path", [REPO_ROOT / "params.yaml", DEFAULT_PARAMS_PATH], ids=["repository", "packaged"])
def test_params_yaml_spells_each_key_once(path):
    yaml.load(path.read_text(), Loader=_UniqueKeyLoader)


def test_load_params_is_the_rust_default():
    assert load_params() == _core.default_params()
    assert load_params(REPO_ROOT / "params.yaml") == _core.default_params()


def test_params_yaml_spells_out_every_key_with_the_rust_value():
    # Not only "validates to the default": every key is written out (nothing left to serde's
    # defaults) and every value equals Rust's, so the file documents the scenario completely.
    raw = yaml.safe_load((REPO_ROOT / "params.yaml").read_text())
    assert raw["capture"]["count"] is None  # derived: ⌈0.8 N⌉
    assert raw == _plain(_core.default_params())
    assert _core.validate_params(raw, resolve=True)["capture"]["count"] == 4


def test_an_empty_file_is_the_documented_scenario(tmp_path):
    (tmp_path / "p.yaml").write_text("# nothing\n")
    assert load_params(tmp_path / "p.yaml") == _core.default_params()


# --- overrides ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "key", "value"),
    [
        ("world.wolves=8", "world.wolves", 8),
        ("world.ts=0.05", "world.ts", 0.05),
        ("world.border=[-5,-5,5,5]", "world.border", [-5, -5, 5, 5]),
        ("world.feasibility_filter=false", "world.feasibility_filter", False),
        ("policies.targets=still", "policies.targets", "still"),
        ("capture.count=null", "capture.count", None),
        (" world.wolves = 3", "world.wolves", 3),
    ],
)
def test_parse_override_reads_values_as_yaml(text, key, value):
    assert parse_override(text) == (key, value)


@pytest.mark.parametrize("text", ["world.wolves", "=3", "world.wolves=[1,"])
def test_malformed_override_is_a_value_error(text):
    with pytest.raises(ValueError):
        parse_override(text)


def test_overrides_apply_to_a_copy_and_rederive_capture_count():
    base = _core.default_params()
    p = load_params(overrides={"world.wolves": 8, "policies.targets": "still", "world.border": [-5, -5, 5, 5]})
    assert p["world"]["wolves"] == 8 and p["capture"]["count"] is None  # derived, follows N
    assert _core.validate_params(p, resolve=True)["capture"]["count"] == 7  # ⌈0.8 · 8⌉
    assert p["policies"]["targets"] == "still"
    assert list(p["world"]["border"]) == [-5, -5, 5, 5]
    assert base == _core.default_params()
    assert apply_overrides(base, {"world.ts": 0.2})["world"]["ts"] == 0.2 and base["world"]["ts"] == 0.1


def test_override_into_a_value_is_rejected_by_name():
    with pytest.raises(ValueError, match="world.ts"):
        apply_overrides(_core.default_params(), {"world.ts.x": 1})


# --- bad input ----------------------------------------------------------------------------

BAD_OVERRIDES = [
    ({"world.wolvs": 3}, "world.wolvs"),  # unknown key
    ({"wolrd.wolves": 3}, "wolrd"),  # unknown section
    ({"world.wolves": "five"}, "world.wolves"),  # wrong type
    ({"world.ts": "fast"}, "world.ts"),
    ({"world.border": [0, 0, 1]}, "world.border"),
    ({"world.wolves": 0}, "world.wolves"),  # zero / negative counts
    ({"world.targets": 0}, "world.targets"),
    ({"world.wolves": -2}, "world.wolves"),
    ({"obstacles.moving_polygons": -1}, "obstacles.moving_polygons"),
    ({"obstacles.circle_radius": [0, 1]}, "obstacles.circle_radius"),  # radii
    ({"obstacles.circle_radius": [1.0, 0.5]}, "obstacles.circle_radius"),
    ({"obstacles.polygon_size": [-1, 1]}, "obstacles.polygon_size"),
    ({"capture.distance": 0}, "capture.distance"),
    ({"agents.wolf.sense_radius": -3}, "agents.wolf.sense_radius"),
    ({"agents.wolf.v_max": 0}, "agents.wolf.v_max"),  # speeds
    ({"agents.target.v_max": -1.5}, "agents.target.v_max"),
    ({"agents.target.omega_max": math.nan}, "agents.target.omega_max"),
    ({"world.ts": 0}, "world.ts"),
    ({"world.ts": -0.1}, "world.ts"),
    ({"world.ts": math.inf}, "world.ts"),
    ({"world.max_steps": 0}, "world.max_steps"),
    ({"world.border": [5, -10, 5, 10]}, "world.border"),  # x_min ≥ x_max
    ({"world.border": [6, -10, 5, 10]}, "world.border"),
    ({"world.border": [-10, 3, 10, -3]}, "world.border"),
    ({"capture.count": 6}, "capture.count"),  # > wolves
    ({"capture.count": 0}, "capture.count"),
    ({"capture.rule": "surround"}, "capture.rule"),
    ({"policies.wolves": "lion"}, "policies.wolves"),  # unknown policy names
    ({"policies.targets": "flee"}, "policies.targets"),
    ({"formation.spacing": 0.0}, "formation.spacing"),
    ({"formation.bump_delta": 0.0}, "formation.bump_delta"),
    ({"formation.ring_points": 3}, "formation.ring_points"),
    ({"formation.alpha": -1.0}, "formation.alpha"),
    ({"formation.unknown": 1}, "formation.unknown"),
    ({"bvc.safety_radius": -0.1}, "bvc.safety_radius"),
    ({"bvc.d_min": float("nan")}, "bvc.d_min"),
    ({"bvc.assignment_period": 0}, "bvc.assignment_period"),
    ({"bvc.disc_sides": 4}, "bvc.disc_sides"),
    ({"bvc.radius": 0.0}, "bvc.radius"),
    ({"bvc.unknown": 1}, "bvc.unknown"),
]


@pytest.mark.parametrize(("overrides", "key"), BAD_OVERRIDES, ids=[k for _, k in BAD_OVERRIDES])
def test_bad_parameter_is_a_value_error_naming_the_key(overrides, key):
    with pytest.raises(ValueError) as e:
        load_params(overrides=overrides)
    assert key in str(e.value)
    assert "\n" not in str(e.value)


def test_obstacles_that_cannot_be_placed_are_a_spawn_error():
    params = load_params(overrides={"obstacles.static_polygons": 500})  # valid, but infeasible
    with pytest.raises(ValueError, match="spawn.*static polygon"):
        wolfpack.run_episodes(params, 1)


@pytest.mark.parametrize(
    ("content", "what"),
    [("world: [1, 2", "YAML"), ("- 1\n- 2\n", "mapping"), ("world:\n  wolves: 0\n", "world.wolves")],
)
def test_bad_params_file_is_a_value_error(tmp_path, content, what):
    path = tmp_path / "p.yaml"
    path.write_text(content)
    with pytest.raises(ValueError, match=what):
        load_params(path)


def test_missing_params_file_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="cannot read"):
        load_params(tmp_path / "nope.yaml")


def _layout(**changes) -> dict:
    layout = layout_dict()
    layout.update(changes)
    return layout


BAD_LAYOUTS = [
    (_layout(wolves=[[11.0, 0.0, 0.0]] + layout_dict()["wolves"][1:]), "wolf 0.*outside"),
    (_layout(targets=[[0.0, -12.0, 0.0]]), "target 0.*outside"),
    (_layout(wolves=layout_dict()["wolves"][:4] + [[5.0, 5.0, 0.0]]), "wolf 4 overlaps obstacle 0"),
    (_layout(targets=[[-5.0, 5.0, 0.0]]), "target 0 overlaps obstacle 1"),
    (_layout(wolves=[]), "layout.*(wolf|wolves)"),
    (_layout(wolves=[[0.0, 0.0]]), "layout"),  # a pose needs x, y, θ
    (_layout(obstacles=[{"kind": "square", "center": [0, 0]}]), "layout"),
    (_layout(obstacles=[{"kind": "circle", "center": [3, 3], "radius": -1}]), "radius"),
    (_layout(extra=1), "layout"),
]


@pytest.mark.parametrize(("layout", "match"), BAD_LAYOUTS)
def test_bad_layout_is_a_value_error(layout, match):
    with pytest.raises(ValueError, match=match):
        _core.check_layout(_core.default_params(), layout)


@pytest.mark.parametrize(("content", "match"), [("{not json", "not valid JSON"), ("[1, 2]", "JSON object")])
def test_malformed_layout_file_is_a_value_error(tmp_path, content, match):
    path = tmp_path / "layout.json"
    path.write_text(content)
    with pytest.raises(ValueError, match=match):
        load_layout(path)


def test_good_layout_implies_its_agent_counts():
    layout = layout_dict()
    layout["wolves"] = layout["wolves"][:3]
    params = load_params()
    resolved = _core.check_layout(params, layout)
    assert resolved["world"]["wolves"] == 3 and resolved["world"]["targets"] == 1
    assert resolved["capture"]["count"] == 3


# --- property tests -----------------------------------------------------------------------


def fix_cross_field_rules(o: dict) -> dict:
    """Adjusts drawn overrides so that they also satisfy the rules that tie keys together
    (wolves + targets <= 1024, <= 10000 obstacles, capture.count <= wolves, formation
    clearance >= half the wolf diameter)."""
    d = lambda k: o.get(k, default_of(k))  # noqa: E731
    if d("world.wolves") + d("world.targets") > 1024:
        o["world.wolves"] = min(d("world.wolves"), 1023)
        o["world.targets"] = 1024 - o["world.wolves"]
    kinds = ["obstacles.static_circles", "obstacles.moving_circles", "obstacles.static_polygons", "obstacles.moving_polygons"]
    if sum(d(k) for k in kinds) > 10_000:
        for k in kinds:
            o[k] = d(k) // 4
    if d("capture.count") is not None and d("capture.count") > d("world.wolves"):
        o["capture.count"] = d("world.wolves")
    if d("formation.clearance") < d("formation.wolf_diameter") / 2:
        o["formation.clearance"] = d("formation.wolf_diameter") / 2
    return o


@st.composite
def valid_overrides(draw, keys=LEAF_KEYS, max_keys: int = 12) -> dict:
    """A random subset of every numeric key, each drawn inside its documented range (often at a
    bound), then made consistent; defaults fill the rest."""
    chosen = draw(st.sets(st.sampled_from(keys), min_size=1, max_size=max_keys))
    o = {k: draw(valid_value(k)) for k in sorted(chosen)}
    if "capture.count" in o:
        o["capture.count"] = draw(st.none() | st.just(o["capture.count"]))
    return fix_cross_field_rules(o)


@settings(max_examples=150, deadline=None)
@given(valid_overrides())
def test_random_valid_overrides_validate_and_round_trip(overrides):
    p = load_params(overrides=overrides)
    for dotted, value in overrides.items():
        section, *rest = dotted.split(".")
        node = p[section]
        for part in rest:
            node = node[part]
        assert _plain(node) == _plain(value), dotted
    if overrides.get("capture.count", 0) is None:
        resolved = _core.validate_params(p, resolve=True)
        assert resolved["capture"]["count"] == math.ceil(0.8 * p["world"]["wolves"])


positive_floats = st.floats(min_value=1e-3, max_value=1e3, allow_nan=False, allow_infinity=False)
ordered_pair = st.lists(positive_floats, min_size=2, max_size=2).map(sorted)
RANGE_KEYS = ["obstacles.circle_radius", "obstacles.polygon_size"]

invalid_override = st.one_of(
    # Every numeric key: below/above its documented range, NaN/inf, huge, wrong types, nesting.
    st.sampled_from(LEAF_KEYS).flatmap(lambda k: st.tuples(st.just(k), invalid_value(k))),
    st.tuples(st.sampled_from(RANGE_KEYS), ordered_pair.map(lambda r: r[::-1]).filter(lambda r: r[0] != r[1])),
    st.tuples(st.sampled_from(RANGE_KEYS), st.lists(positive_floats, max_size=5).filter(lambda r: len(r) != 2)),
    st.tuples(st.just("world.border"), st.lists(st.floats(-100, 100), min_size=4, max_size=4).filter(lambda b: b[2] - b[0] < 1 or b[3] - b[1] < 1)),
    st.tuples(st.just("capture.count"), st.integers(6, 1000) | st.just(0)),
    st.tuples(st.sampled_from(["policies.wolves", "policies.targets"]), st.text(max_size=8).filter(lambda s: s not in {"seed000", "bvc", "formation", "escape", "random", "still"})),
    st.tuples(st.from_regex(r"\A(world|obstacles|capture)\.[a-z]{1,6}_?[a-z]{0,4}x\Z"), st.integers()),  # unknown keys
)


@settings(max_examples=400, deadline=None)
@given(invalid_override)
def test_random_invalid_overrides_raise_value_error_naming_the_key(pair):
    key, value = pair
    with pytest.raises(ValueError) as e:
        load_params(overrides={key: value})
    # The message names the key (its section and field), on one line.
    assert key.split(".")[0] in str(e.value) and key.split(".")[-1] in str(e.value), str(e.value)
