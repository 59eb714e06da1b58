"""Entity observations (``env.observation: entities``): the rows hold what they say on every task,
the size follows the capacities alone, a flat model still plays beside an entity one, and the
batch writes them deterministically whatever its threads."""

from __future__ import annotations

import numpy as np
import pytest
import wolfpack
from wolfpack.batch import entity_kinds
from wolfpack.task import TASK_ORDER

ENTITIES = {"env.observation": "entities"}
FIELD = {name: k for k, name in enumerate(wolfpack.ENTITY_FIELDS)}
SCALE = 10.0  # metres per unit of a row's positions (docs/interface.md, "Entity observations")


def blocks(side: str, params: dict) -> dict[str, dict]:
    return {b["name"]: b for b in wolfpack.observation_layout(side, params)}


def rows_of(obs: np.ndarray, block: dict) -> np.ndarray:
    return obs[..., block["start"] : block["start"] + block["size"]].reshape(*obs.shape[:-1], block["rows"], block["row_size"])


def in_frame(d: np.ndarray, theta: float) -> np.ndarray:
    """World-frame offsets [..., 2] in the frame of an agent heading ``theta`` (x ahead, y left)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], -1)


@pytest.mark.parametrize("task", TASK_ORDER)
def test_the_rows_hold_the_world_on_every_task(task):
    batch = wolfpack.BatchEnv(task=task, num_envs=2, learners="both", seed=11, **ENTITIES)
    params = batch.params
    out = batch.reset()
    rng = np.random.default_rng(0)
    for _ in range(40):
        out = batch.step(rng.uniform(-1, 1, (2, batch.n_wolves, 2)).astype(np.float32), rng.uniform(-1, 1, (2, batch.n_targets, 2)).astype(np.float32))
    world = batch.world_state(0)
    wolves, targets = np.asarray(world["wolves"]), np.asarray(world["targets"])
    n, m = len(wolves), len(targets)
    caps = params["env"]["entities"]
    wb, tb = blocks("wolves", params), blocks("targets", params)
    assert wb["wolf_rows"]["rows"] == caps["max_wolves"] - 1 and wb["target_rows"]["rows"] == caps["max_targets"]
    assert wb["wolf_rows"]["row_size"] == len(wolfpack.ENTITY_FIELDS)
    r_w = params["agents"]["wolf"]["sense_radius"]
    for i in range(n):
        obs = out["obs_wolves"][0, i]
        me = wolves[i]
        # Every other wolf, nearest first, in this wolf's frame; then padding, all zero.
        others = np.delete(wolves, i, axis=0)
        d = others[:, :2] - me[:2]
        order = np.argsort(np.hypot(d[:, 0], d[:, 1]), kind="stable")
        rows = rows_of(obs, wb["wolf_rows"])
        assert (rows[: n - 1, FIELD["present"]] == 1).all() and (rows[: n - 1, FIELD["wolf"]] == 1).all()
        np.testing.assert_allclose(rows[: n - 1, [FIELD["x"], FIELD["y"]]], in_frame(d[order], me[2]) / SCALE, atol=2e-6)
        assert (rows[n - 1 :] == 0).all()
        # A target within sensing range is where it stands and flagged sensed.
        trows = rows_of(obs, wb["target_rows"])
        for j in range(m):
            dt = targets[j, :2] - me[:2]
            if np.hypot(*dt) <= r_w:
                row = trows[j]
                assert row[FIELD["present"]] == 1 and row[FIELD["sensing"]] == 1
                np.testing.assert_allclose(row[[FIELD["x"], FIELD["y"]]], in_frame(dt, me[2]) / SCALE, atol=2e-6)
        assert (trows[m:] == 0).all()
        # Obstacles nearest first, within range; walls always, at the right distances.
        orows = rows_of(obs, wb["obstacle_rows"])
        dist = orows[orows[:, 0] == 1, FIELD["distance"]] * SCALE
        assert (np.diff(dist) >= -1e-5).all() and (dist <= caps["range"] + 1e-4).all()
        assert (orows[orows[:, 0] == 0] == 0).all()
        x0, y0, x1, y1 = params["world"]["border"]
        walls = rows_of(obs, wb["wall_rows"])
        np.testing.assert_allclose(walls[:, FIELD["distance"]] * SCALE, [me[0] - x0, x1 - me[0], me[1] - y0, y1 - me[1]], atol=1e-4)
    # Each target sees the wolves within its sensing radius only.
    r_t = params["agents"]["target"]["sense_radius"]
    for j in range(m):
        rows = rows_of(out["obs_targets"][0, j], tb["wolf_rows"])
        near = np.hypot(*(wolves[:, :2] - targets[j, :2]).T) <= r_t
        assert rows[:, FIELD["present"]].sum() == near.sum()


def test_the_size_follows_the_capacities_not_the_teams():
    sizes = [(3, 1), (5, 2), (8, 3)]
    dims = {(n, m): wolfpack.BatchEnv(num_envs=1, learners="both", **ENTITIES, **{"env.state": "entities", "world.wolves": n, "world.targets": m}) for n, m in sizes}
    assert len({(b.wolf_obs_dim, b.target_obs_dim, b.state_dim) for b in dims.values()}) == 1
    more = wolfpack.BatchEnv(num_envs=1, learners="both", **ENTITIES, **{"env.entities.max_obstacles": 10})
    assert more.wolf_obs_dim == dims[(3, 1)].wolf_obs_dim + 2 * len(wolfpack.ENTITY_FIELDS)
    # The entity state: one row per agent slot, then the clock.
    b = wolfpack.BatchEnv(num_envs=1, learners="wolves", with_state=True, **ENTITIES, **{"env.state": "entities"})
    state = b.reset()["state"][0]
    width = len(wolfpack.ENTITY_STATE_FIELDS)
    rows = state[:-1].reshape(-1, width)
    assert rows.shape[0] == 8 + 3 and rows[:5, 0].all() and rows[8, 0] == 1 and not rows[5:8].any() and not rows[9:].any()


def test_each_side_keeps_its_own_layout():
    flat = wolfpack.BatchEnv(num_envs=1, learners="both")
    mixed = wolfpack.BatchEnv(num_envs=1, learners="both", **{"env.wolf_observation": "entities"})
    assert mixed.target_obs_dim == flat.target_obs_dim and mixed.wolf_obs_dim != flat.wolf_obs_dim
    assert "wolf_rows" in blocks("wolves", mixed.params) and "wolf_rows" not in blocks("targets", mixed.params)


@pytest.mark.parametrize("threads", [1, 2])
def test_entity_observations_are_deterministic_for_any_thread_count(threads):
    def run(t):
        b = wolfpack.BatchEnv(task="cluttered-v1", num_envs=5, learners="both", seed=4, threads=t, with_state=True, **ENTITIES, **{"env.state": "entities"})
        outs = [b.reset()]
        for _ in range(60):
            outs.append(b.step(np.full((5, b.n_wolves, 2), 0.5, np.float32), np.full((5, b.n_targets, 2), -0.2, np.float32)))
        return np.concatenate([np.concatenate([o["obs_wolves"].ravel(), o["obs_targets"].ravel(), o["state"].ravel()]) for o in outs])

    np.testing.assert_array_equal(run(1), run(threads))


def test_entity_kinds_of_a_side():
    hunt = wolfpack.load_params()
    assert entity_kinds("wolves", hunt) == {"wolf", "target", "obstacle", "wall"}
    assert entity_kinds("targets", hunt) == {"wolf", "obstacle", "wall"}
    two = wolfpack.load_params(overrides={"world.targets": 2})
    assert "target" in entity_kinds("targets", two)
    bare = wolfpack.load_params(overrides={f"obstacles.{k}": 0 for k in ("static_circles", "moving_circles", "static_polygons", "moving_polygons")})
    assert "obstacle" not in entity_kinds("wolves", bare)


@pytest.mark.parametrize(
    "overrides, key",
    [
        ({"world.wolves": 9}, "env.entities.max_wolves"),
        ({"world.targets": 4}, "env.entities.max_targets"),
        ({"env.interaction_row": True}, "env.interaction_row"),
        ({"env.entities.range": 0}, "env.entities.range"),
        ({"env.observation": "sets"}, "env.observation"),
    ],
)
def test_bad_entity_params_name_the_key(overrides, key):
    with pytest.raises(ValueError, match=key.replace(".", r"\.")):
        wolfpack.BatchEnv(num_envs=1, **{**ENTITIES, **overrides})
