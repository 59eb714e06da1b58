"""Observations and rewards of the learning interface against a slow NumPy re-derivation.

The oracle below re-derives, from the module docstring of ``envs/wolfpack/parallel_env.py``
alone (its Observation Space table and Rewards section), every observation vector and every
per-step reward that ``wolfpack.parallel_env(learners="both")`` returns, from the world state
that ``env.unwrapped.world_state()`` shows after the same call. Nothing of wolfpack is used
for the computation: only the public API, to get states and outputs.

Conventions the docstring leaves implicit, taken from rust/core/src/observe.rs and reward.rs:
lidar ray k points at θ + 2πk/K (counter-clockwise); the distance is to the first crossing of
the exact shape (circle; polygon = its edges, vertices in order, non-convex allowed; the arena
rectangle ``world.border`` from inside), clipped to the range and divided by it; a ray starting
inside a circle or polygon reads 0; ties in "nearest first" go to the lower index; the target's
fatigue cap uses t_seen = the step counter before the step in which a wolf was first within the
target's sensing radius (positions before that step's move).

With both sides learning, no scripted law marks the interaction matrix, so the last step's
matrix holds the sensing entries only: wolf i → target j when d ≤ r_w, target j → wolf i when
d ≤ r_t, from the positions before that step's move (all zero after reset).

The pack's last sighting of a target (``env.last_sighting``) is where it stood in the latest
observed state (after reset, or after a step's move) in which some wolf was within r_w of it:
the same distances as the wolf's own "sensed" entries.
"""

from __future__ import annotations

import math

import numpy as np
import wolfpack
from hypothesis import given, settings
from hypothesis import strategies as st

ATOL = 1e-5


# ----------------------------------------------------------------------------------------------
# The oracle
# ----------------------------------------------------------------------------------------------


def common(a, v_max, omega_max, border, t, max_steps):
    """Entries 0–8: own speed, turn rate, heading, wall distances, clock."""
    x, y, th, v, om = a
    x0, y0, x1, y1 = border
    w, h = x1 - x0, y1 - y0
    return [v / v_max, om / omega_max, math.sin(th), math.cos(th), (x - x0) / w, (x1 - x) / w, (y - y0) / h, (y1 - y) / h, t / max_steps]


def relative(me, other, scale, flag):
    """``other`` in ``me``'s frame (x ahead, y left): [1,] dx·scale, dy·scale, sin Δθ, cos Δθ."""
    dx, dy = other[0] - me[0], other[1] - me[1]
    c, s = math.cos(me[2]), math.sin(me[2])
    dth = other[2] - me[2]
    return ([1.0] if flag else []) + [(c * dx + s * dy) * scale, (-s * dx + c * dy) * scale, math.sin(dth), math.cos(dth)]


def by_distance(me, agents, skip=None):
    """Indices of ``agents`` nearest first (ties: lower index), with their distances."""
    d = [(math.hypot(a[0] - me[0], a[1] - me[1]), j) for j, a in enumerate(agents) if j != skip]
    return sorted(d)


def inside_polygon(poly, p):
    """Winding number ≠ 0 (a simple polygon, vertices in order)."""
    wn = 0
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        cross = (b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1])
        if a[1] <= p[1] < b[1] and cross > 0:
            wn += 1
        elif b[1] <= p[1] < a[1] and cross < 0:
            wn -= 1
    return wn != 0


def lidar(me, obstacles, border, rays, reach):
    """Ray k at θ + 2πk/K: first hit on a wall, circle or polygon edge, / range, in [0, 1]."""
    o = np.array(me[:2])
    ang = me[2] + 2 * np.pi * np.arange(rays) / rays
    u = np.stack([np.cos(ang), np.sin(ang)], axis=1)  # [K, 2]
    x0, y0, x1, y1 = border
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(u[:, 0] > 0, (x1 - o[0]) / u[:, 0], np.where(u[:, 0] < 0, (x0 - o[0]) / u[:, 0], np.inf))
        ty = np.where(u[:, 1] > 0, (y1 - o[1]) / u[:, 1], np.where(u[:, 1] < 0, (y0 - o[1]) / u[:, 1], np.inf))
    best = np.minimum(np.minimum(tx, ty), reach)
    hits = np.zeros(rays, dtype=int)  # 0 wall/none, 1 circle, 2 polygon
    for ob in obstacles:
        if ob["kind"] == "circle":
            rel = o - np.asarray(ob["center"])
            b, c = u @ rel, rel @ rel - ob["radius"] ** 2
            disc = b * b - c
            with np.errstate(invalid="ignore"):
                t = np.where(c <= 0, 0.0, np.where((disc >= 0) & (-b - np.sqrt(disc) >= 0), -b - np.sqrt(disc), np.inf))
            kind = 1
        else:
            v = np.asarray(ob["vertices"])
            if inside_polygon(v, o):
                t = np.zeros(rays)
            else:
                a, e = v, np.roll(v, -1, axis=0) - v  # edges a + s·e, s ∈ [0, 1]
                ao = a - o  # [E, 2]
                den = u[:, None, 0] * e[None, :, 1] - u[:, None, 1] * e[None, :, 0]  # u × e, [K, E]
                with np.errstate(divide="ignore", invalid="ignore"):
                    tt = (ao[None, :, 0] * e[None, :, 1] - ao[None, :, 1] * e[None, :, 0]) / den
                    ss = (ao[None, :, 0] * u[:, None, 1] - ao[None, :, 1] * u[:, None, 0]) / den
                ok = (den != 0) & (tt >= 0) & (ss >= 0) & (ss <= 1)
                t = np.where(ok, tt, np.inf).min(axis=1)
            kind = 2
        hits = np.where(t < best, kind, hits)
        best = np.minimum(best, t)
    return list(np.clip(best / reach, 0.0, 1.0)), hits


def fatigue_cap(p, t_seen, t):
    side, esc = p["agents"]["target"], p["escape"]
    if t_seen is None or not side["fatigue"]:
        return 1.0
    v = esc["fatigue_base"] * (2 - 1 / (1 + math.exp(esc["fatigue_slope"] * (esc["fatigue_delay"] + t_seen - t))))
    return min(v, side["v_max"]) / side["v_max"]


def sensing(p, ws):
    """The sensing entries of the interaction matrix for ``ws``'s positions (see module doc)."""
    n, m = len(ws["wolves"]), len(ws["targets"])
    rw, rt = p["agents"]["wolf"]["sense_radius"], p["agents"]["target"]["sense_radius"]
    mat = np.zeros((n + m, n + m))
    for i, w in enumerate(ws["wolves"]):
        for j, tg in enumerate(ws["targets"]):
            d = math.hypot(w[0] - tg[0], w[1] - tg[1])
            mat[i, n + j] = d <= rw
            mat[n + j, i] = d <= rt
    return mat


def note_sightings(p, ws, sighting):
    """Updates ``sighting[j]`` = (x, y, step) for every target some wolf senses in ``ws``."""
    for j, tg in enumerate(ws["targets"]):
        if np.any(np.hypot(*(ws["wolves"][:, :2] - tg[:2]).T) <= p["agents"]["wolf"]["sense_radius"]):
            sighting[j] = (tg[0], tg[1], ws["step"])


def sighting_block(me, sighting, S, T, t):
    """Per target: sighted, dx/S, dy/S (wolf frame), age / max_steps; zeros before the first."""
    out = []
    for s in sighting:
        if s is None:
            out += [0.0] * 4
            continue
        dx, dy = s[0] - me[0], s[1] - me[1]
        c, si = math.cos(me[2]), math.sin(me[2])
        out += [1.0, (c * dx + si * dy) / S, (-si * dx + c * dy) / S, (t - s[2]) / T]
    return out


def expected_obs(p, ws, t_seen, row_matrix, stats, sighting=()):
    """Every agent's observation for world state ``ws`` (docstring table, row by row)."""
    wp, tp, env = p["agents"]["wolf"], p["agents"]["target"], p["env"]
    border, T, t = p["world"]["border"], p["world"]["max_steps"], ws["step"]
    S = max(border[2] - border[0], border[3] - border[1])
    K, reach = env["lidar"]["rays"], env["lidar"]["range"]
    wolves, targets = ws["wolves"], ws["targets"]
    out = {}
    for i, me in enumerate(wolves):
        o = common(me, wp["v_max"], wp["omega_max"], border, t, T)
        for tg in targets:
            sensed = math.hypot(tg[0] - me[0], tg[1] - me[1]) <= wp["sense_radius"]
            o += relative(me, tg, 1 / wp["sense_radius"], True) if sensed else [0.0] * 5
            stats["wolf_sensed"] += sensed
        for _, j in by_distance(me, wolves, skip=i):
            # the partner's flag: does wolf j have any target within its sensing radius now?
            partner_senses = any(math.hypot(tg[0] - wolves[j][0], tg[1] - wolves[j][1]) <= wp["sense_radius"] for tg in targets)
            o += [float(partner_senses)] + relative(me, wolves[j], 1 / S, False)
            stats["partner_senses"] += partner_senses
        out[f"wolf_{i}"] = o
    for j, me in enumerate(targets):
        o = common(me, tp["v_max"], tp["omega_max"], border, t, T) + [fatigue_cap(p, t_seen[j], t)]
        stats["cap_below_1"] += o[-1] < 1
        for d, i in by_distance(me, wolves):
            o += relative(me, wolves[i], 1 / tp["sense_radius"], True) if d <= tp["sense_radius"] else [0.0] * 5
            stats["target_masked"] += d > tp["sense_radius"]
        out[f"target_{j}"] = o
    for k, (a, me) in enumerate([(f"wolf_{i}", w) for i, w in enumerate(wolves)] + [(f"target_{j}", x) for j, x in enumerate(targets)]):
        ray, hits = lidar(me, ws["obstacles"], border, K, reach)
        out[a] += ray
        for h in range(3):
            stats[("wall", "circle", "polygon")[h]] += int(np.sum((hits == h) & (np.array(ray) < 1)))
        stats["inside"] += int(np.sum(np.array(ray) == 0))
        if env["last_sighting"] and a.startswith("wolf"):
            out[a] += sighting_block(me, sighting, S, T, t)
            stats["sighting_away"] += sum(s is not None and s[2] < t for s in sighting)
        if env["interaction_row"]:
            out[a] += list(row_matrix[k])
    return {a: np.array(v) for a, v in out.items()}


def potential(p, ws, captured):
    """Φ per wolf: −|d − r_h|, d to the nearest uncaptured target (``shaping_focus: nearest``) or
    to the uncaptured target with the least total distance to the wolves (``pack``); 0 at a
    capture or collision."""
    if ws["outcome"] in ("captured", "collision"):
        return np.zeros(len(ws["wolves"]))
    tg = ws["targets"][~captured]
    d = np.hypot(ws["wolves"][:, None, 0] - tg[None, :, 0], ws["wolves"][:, None, 1] - tg[None, :, 1])
    d = d.min(axis=1) if p["rewards"]["wolves"]["shaping_focus"] == "nearest" else d[:, np.argmin(d.sum(axis=0))]
    return -np.abs(d - p["seed000"]["radius"])


def expected_rewards(p, before, after, infos_before, infos_after, agents):
    """Rewards of the step ``before`` → ``after`` for the agents active in it."""
    rw, rt = p["rewards"]["wolves"], p["rewards"]["targets"]
    newly = int(np.sum(after["captured"] & ~before["captured"]))
    shaping = rw["shaping"] * (potential(p, after, after["captured"]) - potential(p, before, before["captured"]))
    out = {}
    for a in agents:
        kind, k = a.rsplit("_", 1)
        k = int(k)
        collided = infos_after[a]["collisions"] > infos_before[a]["collisions"]
        if kind == "wolf":
            out[a] = -rw["time_penalty"] + rw["capture_bonus"] * newly + shaping[k] - rw["collision_penalty"] * collided
        elif before["captured"][k]:
            out[a] = 0.0
        else:
            out[a] = (-rt["capture_penalty"] if after["captured"][k] else rt["survival"]) - rt["collision_penalty"] * collided
    return out


# ----------------------------------------------------------------------------------------------
# Driving the env and comparing
# ----------------------------------------------------------------------------------------------


def new_stats():
    keys = (
        "steps",
        "wolf_sensed",
        "partner_senses",
        "target_masked",
        "cap_below_1",
        "wall",
        "circle",
        "polygon",
        "inside",
        "captures",
        "wolf_collisions",
        "target_collisions",
        "row_ones",
        "sighting_away",
    )
    return dict.fromkeys(keys, 0)


def run(env, seed, steps, expert_share, stats, layout=None, actions=None):
    """Reset with ``seed`` and step; compare every observation and reward with the oracle.
    Each agent follows the expert with probability ``expert_share``, else a uniform random
    action (or ``actions(t, agent)`` when given). A finished episode is reset with seed + 1000 + t
    (or ends the run, when it started from ``layout``)."""
    u = env.unwrapped
    p = u.params
    rng = np.random.default_rng(seed)
    n, m = p["world"]["wolves"], p["world"]["targets"]
    rt = p["agents"]["target"]["sense_radius"]
    obs, infos = env.reset(seed=seed, options={"layout": layout} if layout else None)
    ws = u.world_state()
    t_seen, sighting = [None] * m, [None] * m
    zero = np.zeros((n + m, n + m))
    note_sightings(p, ws, sighting)
    compare(p, ws, obs, t_seen, zero, stats, ctx=f"seed {seed} reset", sighting=sighting)
    for t in range(steps):
        if not env.agents:
            if layout is not None:
                break
            obs, infos = env.reset(seed=seed + 1000 + t)
            ws, t_seen, sighting = u.world_state(), [None] * m, [None] * m
            note_sightings(p, ws, sighting)
            compare(p, ws, obs, t_seen, zero, stats, ctx=f"seed {seed} re-reset at {t}", sighting=sighting)
            continue
        expert = u.expert_actions()
        act = {}
        for a in env.agents:
            if actions is not None:
                act[a] = np.asarray(actions(t, a), np.float32)
            elif rng.random() < expert_share:
                act[a] = expert[a]
            else:
                act[a] = rng.uniform(-1, 1, 2).astype(np.float32)
        agents = list(env.agents)
        # t_seen: the step counter before the first step whose pre-move positions put a wolf
        # within the target's sensing radius.
        for j, tg in enumerate(ws["targets"]):
            if t_seen[j] is None and np.any(np.hypot(*(ws["wolves"][:, :2] - tg[:2]).T) <= rt):
                t_seen[j] = ws["step"]
        rows = sensing(p, ws)
        obs, rewards, terms, truncs, infos_after = env.step(act)
        after = u.world_state()
        note_sightings(p, after, sighting)
        compare(p, after, obs, t_seen, rows, stats, ctx=f"seed {seed} step {after['step']}", sighting=sighting)
        want = expected_rewards(p, ws, after, infos, infos_after, agents)
        assert set(rewards) == set(agents)
        got_r = np.array([rewards[a] for a in agents])
        want_r = np.array([want[a] for a in agents])
        np.testing.assert_allclose(got_r, want_r, rtol=0, atol=ATOL, err_msg=f"rewards, seed {seed} step {after['step']}: {agents}")
        stats["captures"] += int(np.sum(after["captured"] & ~ws["captured"]))
        for a in agents:
            if infos_after[a]["collisions"] > infos[a]["collisions"]:
                stats["wolf_collisions" if a.startswith("wolf") else "target_collisions"] += 1
        stats["row_ones"] += int(rows.sum())
        stats["steps"] += 1
        ws, infos = after, infos_after
    return stats


def compare(p, ws, obs, t_seen, rows, stats, ctx, sighting=()):
    want = expected_obs(p, ws, t_seen, rows, stats, sighting)
    for a, got in obs.items():
        assert got.dtype == np.float32 and got.shape == want[a].shape, (ctx, a, got.shape, want[a].shape)
        bad = np.flatnonzero(np.abs(got - want[a]) > ATOL)
        assert bad.size == 0, f"{ctx} {a}: entries {bad.tolist()} got {got[bad].tolist()} want {want[a][bad].tolist()}"


# ----------------------------------------------------------------------------------------------
# Tests
# ----------------------------------------------------------------------------------------------


def test_default_scenario_fixed_seeds():
    """5 wolves, 1 target, 12 obstacles (circles, polygons, moving): observations and rewards
    on 6 seeds, 40 steps each, half expert / half random actions; the branches are exercised."""
    env = wolfpack.parallel_env(learners="both")
    stats = new_stats()
    for seed in range(6):
        run(env, seed, 40, 0.5, stats)
    assert stats["steps"] >= 200, stats
    for key in ("wolf_sensed", "partner_senses", "target_masked", "wall", "circle", "polygon"):
        assert stats[key] > 0, (key, stats)


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), expert_share=st.sampled_from([0.0, 0.5, 0.9]))
def test_default_scenario_random_seeds(seed, expert_share):
    env = wolfpack.parallel_env(learners="both")
    run(env, seed, 25, expert_share, new_stats())


def test_three_wolves_two_targets_interaction_row_and_lidar_7():
    """3 wolves, 2 targets, interaction row, 7 rays of 4.5 m, a 20 × 14 arena (W ≠ H, S = 20)
    and a short fatigue delay, so that the target's cap entry falls below 1 within the run."""
    overrides = {"world.wolves": 3, "world.targets": 2, "env.interaction_row": True, "env.lidar.rays": 7, "env.lidar.range": 4.5, "world.border": [-10.0, -7.0, 10.0, 7.0], "escape.fatigue_delay": 4.0}
    env = wolfpack.parallel_env(learners="both", **overrides)
    p = env.unwrapped.params
    assert p["env"]["lidar"]["rays"] == 7 and list(p["world"]["border"]) == [-10.0, -7.0, 10.0, 7.0]
    stats = new_stats()
    for seed in range(4):
        run(env, seed, 50, 0.8, stats)
    for key in ("wolf_sensed", "partner_senses", "target_masked", "cap_below_1", "wall", "circle", "polygon", "row_ones"):
        assert stats[key] > 0, (key, stats)


def test_pack_shaping_focus_with_two_targets():
    """``shaping_focus: pack``: every wolf's shaping measures its distance to one target, the
    one nearest the pack as a whole; checked step by step against the reference above, on seeds
    where some wolf's own nearest target is not the pack's (else the check could not fail)."""
    env = wolfpack.parallel_env(learners="both", **{"world.targets": 2, "rewards.wolves.shaping_focus": "pack"})
    split = 0
    for seed in range(3):
        env.reset(seed=seed)
        ws = env.unwrapped.world_state()
        d = np.hypot(ws["wolves"][:, None, 0] - ws["targets"][None, :, 0], ws["wolves"][:, None, 1] - ws["targets"][None, :, 1])
        split += int(np.any(d.argmin(axis=1) != d.sum(axis=0).argmin()))
        run(env, seed, 40, 0.8, new_stats())
    assert split > 0


def test_last_sighting_two_targets():
    """The pack's last sighting (two targets, four wolves, mostly random moves so that targets
    are lost and found again): every wolf's block against the oracle, with stale sightings seen."""
    env = wolfpack.parallel_env(learners="both", **{"world.wolves": 4, "world.targets": 2, "env.last_sighting": True})
    assert env.observation_space("wolf_0").shape == (9 + 5 * 2 + 5 * 3 + 16 + 4 * 2,)
    assert env.observation_space("target_0").shape == (10 + 5 * 4 + 16,)
    stats = new_stats()
    for seed in range(4):
        run(env, seed, 60, 0.3, stats)
    for key in ("wolf_sensed", "sighting_away"):
        assert stats[key] > 0, (key, stats)


def ring_layout(second_target=True):
    """Four wolves 0.75 m around target 0 (capture distance 0.8, count 4: captured on step 1),
    a fifth wolf and optionally a second target far away; one static circle near wolf 4."""
    lay = {
        "wolves": [[0.75, 0.0, math.pi], [-0.75, 0.0, 0.0], [0.0, 0.75, 4.712], [0.0, -0.75, 1.5708], [-6.0, 5.0, 0.0]],
        "targets": [[0.0, 0.0, 0.0]] + ([[-6.0, 7.0, 0.3]] if second_target else []),
        "obstacles": [{"kind": "circle", "center": [6.0, -6.0], "radius": 0.8, "moving": False}],
    }
    return lay


STAY = np.array([-1.0, 0.0], np.float32)  # v = 0, ω = 0


def test_rewards_capture_with_two_targets():
    """Target 0 is captured at step 1 while target 1 plays on: every wolf gets the bonus,
    shaping switches to the nearest *uncaptured* target, target 0 gets −capture_penalty, and
    (BatchEnv, which reports every target) 0 afterwards while target 1 keeps its survival reward."""
    env = wolfpack.parallel_env(learners="both", **{"world.targets": 2})
    stats = run(env, 0, 6, 0.0, new_stats(), layout=ring_layout(), actions=lambda t, a: STAY)
    assert stats["captures"] == 1, stats
    batch = wolfpack.BatchEnv(learners="both", num_envs=1, autoreset=False, threads=1, **{"world.targets": 2})
    batch.reset_world(0, 0, ring_layout())
    rewards = [batch.step(np.tile(STAY, (1, 5, 1)), np.tile(STAY, (1, 2, 1)))["rewards_targets"][0] for _ in range(3)]
    rt = batch.params["rewards"]["targets"]
    np.testing.assert_allclose(np.array(rewards), [[-rt["capture_penalty"], rt["survival"]], [0.0, rt["survival"]], [0.0, rt["survival"]]], atol=ATOL)


def test_rewards_terminal_capture():
    """Φ = 0 at a terminal capture (one target): the wolves' shaping is +|d − r_h| of the last state."""
    env = wolfpack.parallel_env(learners="both")
    stats = run(env, 0, 3, 0.0, new_stats(), layout=ring_layout(second_target=False), actions=lambda t, a: STAY)
    assert stats["captures"] == 1 and stats["steps"] == 1, stats


FAR_WOLVES = [[-6.0, 6.0, 0.0], [-3.0, 6.0, 0.0], [0.0, 6.0, 0.0], [3.0, 6.0, 0.0], [6.0, 6.0, 0.0]]
FULL = np.array([1.0, 0.0], np.float32)  # v = v_max, ω = 0
NO_FILTER = {"world.feasibility_filter": False}


def test_wolf_collision_is_terminal_with_zero_potential():
    """Without the feasibility filter wolf 4 drives into a circle: −collision_penalty, Φ(s') = 0."""
    lay = {"wolves": FAR_WOLVES[:4] + [[3.0, -6.0, 0.0]], "targets": [[-6.0, 2.0, 0.0]], "obstacles": [{"kind": "circle", "center": [6.0, -6.0], "radius": 0.8, "moving": False}]}
    env = wolfpack.parallel_env(learners="both", **NO_FILTER)
    stats = run(env, 0, 40, 0.0, new_stats(), layout=lay, actions=lambda t, a: FULL if a == "wolf_4" else STAY)
    assert stats["wolf_collisions"] == 1 and env.unwrapped.world_state()["outcome"] == "collision", stats


def test_target_drives_through_a_circle_and_a_non_convex_polygon():
    """Without the feasibility filter the target drives straight through a circle and then
    through a non-convex polygon (which spins in place: static polygons rotate): the collision
    penalty every step in contact, and lidar rays starting inside an obstacle read 0."""
    notch = [[4.0, -7.0], [6.0, -7.0], [6.0, -5.0], [4.0, -5.0], [5.0, -6.0]]
    lay = {
        "wolves": FAR_WOLVES,
        "targets": [[-3.0, -5.9, 0.0]],
        "obstacles": [{"kind": "circle", "center": [0.0, -6.0], "radius": 0.8, "moving": False}, {"kind": "polygon", "center": [5.2, -6.0], "vertices": notch, "moving": False}],
    }
    env = wolfpack.parallel_env(learners="both", **NO_FILTER)
    stats = run(env, 0, 60, 0.0, new_stats(), layout=lay, actions=lambda t, a: FULL if a == "target_0" else STAY)
    assert stats["steps"] == 60 and stats["target_collisions"] >= 15 and stats["inside"] >= 15 * 16, stats  # ~11 steps in the circle, ~7 in the polygon
