"""The learning interface: PettingZoo, Gymnasium and SB3 conformance, determinism, the expert,
observations that follow the sensing topology, and bad input."""

from __future__ import annotations

import pickle

import gymnasium
import numpy as np
import pytest
import wolfpack
from hypothesis import given, settings
from hypothesis import strategies as st
from pettingzoo.test import parallel_api_test, parallel_seed_test
from wolfpack.parallel_env import OBS_BOUND

# A 5-wolf, 1-target layout with no obstacles: wolf 0 at the origin facing +y, the target 2 m
# ahead of it (sensed), the other wolves far away.
LAYOUT = {
    "wolves": [[0.0, 0.0, np.pi / 2], [6.0, 6.0, 0.0], [-6.0, 6.0, 0.0], [6.0, -6.0, 0.0], [-6.0, -6.0, 0.0]],
    "targets": [[0.0, 2.0, np.pi]],
    "obstacles": [],
}


# --- conformance ---------------------------------------------------------------------------


@pytest.mark.parametrize("learners", ["wolves", "targets", "both"])
def test_pettingzoo_parallel_api(learners):
    parallel_api_test(wolfpack.parallel_env(learners=learners), num_cycles=400)


@pytest.mark.parametrize("learners", ["wolves", "targets", "both"])
def test_pettingzoo_seed_test(learners):
    parallel_seed_test(lambda: wolfpack.parallel_env(learners=learners), num_cycles=50)


def test_gymnasium_and_sb3_checkers_pass_on_escape_v0():
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gymnasium.make("wolfpack/Escape-v0")
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(gymnasium.make("wolfpack/Escape-v0").unwrapped)


def test_sb3_ppo_trains_on_make_vec_env():
    from stable_baselines3 import PPO

    venv = wolfpack.make_vec_env(num_envs=4, seed=0)
    model = PPO("MlpPolicy", venv, n_steps=128, batch_size=256, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=3000)
    assert model.num_timesteps >= 3000
    obs = venv.reset()
    action, _ = model.predict(obs, deterministic=True)
    assert action.shape == (venv.num_envs, 2)


# --- determinism ---------------------------------------------------------------------------


def _rollout_parallel(seed: int, steps: int = 500):
    env = wolfpack.parallel_env(learners="both")
    rng = np.random.default_rng(1)
    obs, infos = env.reset(seed=seed)
    trace = [obs, infos]
    for _ in range(steps):
        if not env.agents:
            obs, infos = env.reset()
            trace += [obs, infos]
            continue
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}
        trace.append(env.step(actions))
    return trace


def _equal(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and np.array_equal(a, b)
    return a == b


def test_same_seed_same_500_steps_different_seed_differs():
    a, b, c = _rollout_parallel(3), _rollout_parallel(3), _rollout_parallel(4)
    assert _equal(a, b)
    assert not _equal(a, c)


@pytest.mark.parametrize("learners", ["wolves", "targets"])
def test_make_vec_env_is_bit_identical_for_any_thread_count(learners):
    def rollout(threads):
        venv = wolfpack.make_vec_env(num_envs=8, learners=learners, seed=5, threads=threads)
        rng = np.random.default_rng(0)
        out = [venv.reset()]
        for _ in range(400):  # past the 300-step limit: autoresets included
            obs, rew, done, infos = venv.step(rng.uniform(-1, 1, (venv.num_envs, 2)).astype(np.float32))
            out += [obs, rew, done, [i.get("terminal_observation") for i in infos]]
        return out

    assert _equal(rollout(1), rollout(2))


# --- the expert ----------------------------------------------------------------------------


def test_following_the_expert_matches_wolfpack_hunt_within_3_points():
    episodes = 200
    hunt = wolfpack.summarize(wolfpack.run_episodes(wolfpack.load_params(), seed=0, episodes=episodes))
    env = wolfpack.parallel_env(learners="wolves")
    captured = 0
    for k in range(episodes):
        env.reset(seed=k)
        infos = {}
        while env.agents:
            _, _, _, _, infos = env.step(env.unwrapped.expert_actions())
        captured += wolfpack.OUTCOMES[next(iter(infos.values()))["outcome"]] == "captured"
    assert abs(captured / episodes - hunt["capture_rate"]) <= 0.03, (captured, hunt)


def test_escape_expert_reproduces_the_scripted_target():
    env = gymnasium.make("wolfpack/Escape-v0").unwrapped
    outcomes = []
    for k in range(40):
        env.reset(seed=k)
        done = False
        while not done:
            _, _, term, trunc, info = env.step(env.expert_actions())
            done = term or trunc
        outcomes.append(wolfpack.OUTCOMES[info["outcome"]])
    hunt = wolfpack.run_episodes(wolfpack.load_params(), seed=0, episodes=40)
    assert abs(outcomes.count("captured") - sum(r["outcome"] == "captured" for r in hunt)) <= 2


# --- observations, layouts, world_state ----------------------------------------------------


def test_layout_reset_and_world_state():
    env = wolfpack.parallel_env(learners="wolves")
    obs, _ = env.reset(seed=0, options={"layout": LAYOUT})
    s = env.unwrapped.world_state()
    assert s["wolves"].shape == (5, 5) and s["targets"].shape == (1, 5)
    np.testing.assert_allclose(s["wolves"][0, :3], [0.0, 0.0, np.pi / 2])
    assert s["interaction"].shape == (6, 6) and s["interaction"].dtype == np.uint8
    assert s["obstacles"] == [] and s["step"] == 0 and s["energy"].shape == (6,)
    # Wolf 0 senses the target 2 m straight ahead: flag 1, (dx, dy)/3 = (2/3, 0).
    np.testing.assert_allclose(obs["wolf_0"][9:12], [1.0, 2 / 3, 0.0], atol=1e-6)
    # Wolf 1 is 6+ m away: the target block is all zero — the sensing topology matters.
    assert not obs["wolf_1"][9:14].any()


def test_layout_with_other_agent_counts_is_rejected():
    env = wolfpack.parallel_env()
    bad = dict(LAYOUT, wolves=LAYOUT["wolves"][:3])
    with pytest.raises(ValueError, match="3 wolves"):
        env.reset(options={"layout": bad})


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), scale=st.floats(0.1, 5.0))
def test_observations_stay_in_their_space_and_rewards_are_finite(seed, scale):
    env = wolfpack.parallel_env(learners="both")
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(60):
        if not env.agents:
            break
        acts = {a: (rng.normal(size=2) * scale).astype(np.float32) for a in env.agents}
        obs, rew, *_ = env.step(acts)
        for a, o in obs.items():
            assert o.dtype == np.float32 and env.observation_space(a).contains(o), (a, o)
            assert np.abs(o).max() <= OBS_BOUND
        assert all(np.isfinite(r) for r in rew.values())


# --- SB3 VecEnv semantics ------------------------------------------------------------------


def test_vec_env_autoreset_terminal_observation_and_truncation():
    venv = wolfpack.make_vec_env(num_envs=3, seed=0, **{"world.max_steps": 4})
    assert venv.num_envs == 15
    venv.reset()
    zeros = np.zeros((15, 2), np.float32)
    for _ in range(3):
        _, _, dones, infos = venv.step(zeros)
        assert not dones.any()
    obs, _, dones, infos = venv.step(zeros)
    assert dones.all()
    for k, info in enumerate(infos):
        assert info["TimeLimit.truncated"] is True and info["outcome"] == 3 and info["outcome_name"] == "timeout"
        assert info["terminal_observation"][8] == 1.0  # clock 4/4 in the final observation
        assert obs[k][8] == 0.0  # the new episode's first observation
    assert venv.get_attr("world_index", [0, 5, 14]) == [0, 1, 2]
    assert venv.get_attr("agent", [6]) == ["wolf_1"]
    venv.set_attr("render_mode", "x", [0])
    assert venv.get_attr("render_mode", [0, 1]) == ["x", None]
    assert venv.env_is_wrapped(gymnasium.Wrapper) == [False] * 15
    assert venv.env_method("world_state", indices=[0])[0]["wolves"].shape == (5, 5)
    assert venv.env_method("expert_action", indices=[3])[0].shape == (2,)
    assert venv.seed(7)[:6] == [7] * 5 + [8]


def test_one_worlds_agent_infos_are_that_worlds_share_of_every_worlds():
    """``world_agent_infos`` (what a VecEnv builds for a world that ended) gives, for any world
    and any range of agents, the very dicts of ``agent_infos`` over the whole output: the same
    keys, values and Python types — over captures, cornerings, collisions and timeouts, with
    two targets so that the capture steps of wolves and targets differ."""
    from wolfpack.views import agent_infos, world_agent_infos

    batch = wolfpack.BatchEnv(num_envs=12, learners="none", seed=5, **{"world.targets": 2, "capture.cornered": True, "world.max_steps": 150})
    batch.reset()
    n, m = batch.n_wolves, batch.n_targets
    outcomes = set()
    for t in range(300):
        out = batch.step()
        outcomes |= set(out["outcome"].tolist())
        if t % 5:
            continue
        for lo, hi in [(0, n), (0, n + m), (n, n + m), (2, n + 1), (n + 1, n + 2)]:
            every = agent_infos(out, n, lo, hi)
            for e in range(batch.num_envs):
                mine = world_agent_infos(out, e, n, lo, hi)
                want = every[e * (hi - lo) : (e + 1) * (hi - lo)]
                assert [[(k, v, type(v)) for k, v in d.items()] for d in mine] == [[(k, v, type(v)) for k, v in d.items()] for d in want], (t, e, lo, hi)
    # Running, timed-out and succeeded (captured or cornered: a world capture step) worlds.
    assert {0, 3} <= outcomes and outcomes & {1, 4}, outcomes


def test_vec_env_infos_are_built_only_for_slots_whose_world_ended():
    """Running slots share one empty read-only mapping (SB3 only reads them); the slots of a
    world that ended get dicts of their own whose numbers are that world's row of
    ``step_infos``; reset infos carry every slot's numbers."""
    from stable_baselines3.common.vec_env import VecMonitor

    venv = wolfpack.make_vec_env(num_envs=4, seed=3, **{"world.max_steps": 30})
    venv.reset()
    assert len(venv.reset_infos) == 20 and venv.reset_infos[7]["outcome_name"] == "running"
    assert venv.reset_infos[7]["distance"] == float(venv.step_infos["distance"][1, 2])
    rng = np.random.default_rng(0)
    ended_seen = 0
    for _ in range(40):
        _, _, dones, infos = venv.step(rng.uniform(-1, 1, (20, 2)).astype(np.float32))
        assert len(infos) == 20
        for k, info in enumerate(infos):
            e, i = divmod(k, 5)
            if not dones[k]:
                assert info is wolfpack.vec_env.RUNNING_INFO and info.get("terminal_observation") is None
                continue
            ended_seen += 1
            assert info is not wolfpack.vec_env.RUNNING_INFO and info["terminal_observation"].shape == (50,)
            row = venv.step_infos
            assert info["outcome"] == int(row["outcome"][e]) and info["outcome"] != 0
            assert info["energy"] == float(row["energy"][e, i]) and info["collisions"] == int(row["collisions"][e, i])
            assert info["outcome_name"] == wolfpack.OUTCOMES[info["outcome"]]
    assert ended_seen >= 20, "every world ends within 30 steps"
    with pytest.raises(TypeError):
        wolfpack.vec_env.RUNNING_INFO["x"] = 1  # type: ignore[index]
    # SB3's own wrapper copies a done slot's info before adding "episode" and leaves the rest.
    monitored = VecMonitor(wolfpack.make_vec_env(num_envs=2, seed=0, **{"world.max_steps": 5}))
    monitored.reset()
    for _ in range(5):
        _, _, dones, infos = monitored.step(np.zeros((10, 2), np.float32))
    assert dones.all() and all(info["episode"]["l"] == 5 for info in infos)


def test_envs_pickle_by_constructor_arguments():
    for env in (
        wolfpack.parallel_env(learners="targets", **{"world.wolves": 4}),
        gymnasium.make("wolfpack/Escape-v0").unwrapped,
        wolfpack.make_vec_env(num_envs=2, learners="targets"),
        wolfpack.BatchEnv(num_envs=2, seed=3),
    ):
        clone = pickle.loads(pickle.dumps(env))
        assert type(clone) is type(env)
        assert clone.params == env.params if hasattr(env, "params") else True


# --- bad input -----------------------------------------------------------------------------


def test_parallel_env_bad_actions_name_the_agent():
    env = wolfpack.parallel_env(learners="both")
    env.reset(seed=0)
    good = {a: np.zeros(2, np.float32) for a in env.agents}
    with pytest.raises(ValueError, match="wolf_3"):
        env.step({a: v for a, v in good.items() if a != "wolf_3"})
    with pytest.raises(ValueError, match="wolf_9"):
        env.step({**good, "wolf_9": np.zeros(2, np.float32)})
    with pytest.raises(ValueError, match="target_0.*shape"):
        env.step({**good, "target_0": np.zeros(3, np.float32)})
    with pytest.raises(ValueError, match="wolf_1.*dtype"):
        env.step({**good, "wolf_1": np.zeros(2, np.int64)})
    with pytest.raises(ValueError, match="wolf_2.*not finite"):
        env.step({**good, "wolf_2": np.array([np.nan, 0], np.float32)})
    with pytest.raises(ValueError, match="target_0.*not finite"):
        env.step({**good, "target_0": np.array([0, np.inf])})
    # Nothing moved: the world is still at step 0.
    assert env.unwrapped.world_state()["step"] == 0
    env.step(good)
    assert env.unwrapped.world_state()["step"] == 1


def test_stepping_a_finished_episode_is_an_error():
    env = wolfpack.parallel_env(**{"world.max_steps": 2})
    env.reset(seed=0)
    for _ in range(2):
        env.step({a: np.zeros(2, np.float32) for a in env.agents})
    assert env.agents == []
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})


def test_both_sides_learning_has_one_name_and_all_is_its_alias():
    """ "both" is what every interface says and returns; "all" (the first name) still means it."""
    for learners in ("both", "all"):
        batch = wolfpack.BatchEnv(num_envs=2, learners=learners, seed=3)
        assert batch.learners == "both" and batch.learns_wolves and batch.learns_targets
        assert wolfpack.parallel_env(learners=learners).learners == "both"
        assert wolfpack.make_vec_env(num_envs=2, learners=learners, shared_space=True).learners == "both"
    assert "both" in wolfpack.sides.LEARNERS and "all" not in wolfpack.sides.LEARNERS
    with pytest.raises(ValueError, match=r"learners must be one of 'wolves', 'targets', 'both', 'none', got 'sheep'"):
        wolfpack.BatchEnv(learners="sheep")


def test_invalid_learners_and_arguments():
    with pytest.raises(ValueError, match="learners"):
        wolfpack.parallel_env(learners="sheep")
    with pytest.raises(ValueError, match=r"learners='both'\) needs shared_space=True"):
        wolfpack.make_vec_env(num_envs=2, learners="both")
    with pytest.raises(ValueError, match=r"learners='both'\) needs shared_space=True"):
        wolfpack.make_vec_env(num_envs=2, learners="all")
    with pytest.raises(ValueError, match="num_envs"):
        wolfpack.BatchEnv(num_envs=0)
    # Unknown keywords are TypeErrors naming them (Python's convention, which TorchRL's GymEnv
    # relies on to retry without a keyword); bad values of known keys are ValueErrors.
    for make in (wolfpack.parallel_env, lambda **k: gymnasium.make("wolfpack/Escape-v0", **k), lambda **k: wolfpack.make_vec_env(num_envs=1, **k), lambda **k: wolfpack.BatchEnv(**k)):
        with pytest.raises(TypeError, match="'frameskip'"):
            make(frameskip=4)
        with pytest.raises(TypeError, match=r"world\.wolvs' \(did you mean 'world\.wolves'\?\)"):
            make(**{"world.wolvs": 3})
        with pytest.raises(TypeError, match=r"world__wolvs' \(did you mean 'world\.wolves'\?\)"):
            make(world__wolvs=3)
        with pytest.raises(ValueError, match="world.wolves"):
            make(world__wolves=0)
    assert wolfpack.parallel_env(max_cycles=7).params["world"]["max_steps"] == 7  # PettingZoo's name
    with pytest.raises(ValueError, match="render_mode"):
        wolfpack.parallel_env(render_mode="ascii")
    with pytest.raises(ValueError, match="one learning target"):
        gymnasium.make("wolfpack/Escape-v0", world__targets=2)


def test_vec_env_and_batch_bad_actions():
    venv = wolfpack.make_vec_env(num_envs=2)
    venv.reset()
    with pytest.raises(ValueError, match="shape"):
        venv.step(np.zeros((9, 2), np.float32))
    bad = np.zeros((10, 2), np.float32)
    bad[7, 1] = np.nan
    with pytest.raises(ValueError, match="slot 7.*wolf_2 in world 1"):
        venv.step(bad)
    batch = wolfpack.BatchEnv(num_envs=2)
    with pytest.raises(ValueError, match="wolf actions.*shape"):
        batch.step(np.zeros((2, 4, 2), np.float32))
    with pytest.raises(ValueError, match="floating"):
        batch.step(np.zeros((2, 5, 2), np.int32))
    a = np.zeros((2, 5, 2), np.float32)
    a[1, 4, 0] = np.inf
    with pytest.raises(ValueError, match="wolf_4 in world 1"):
        batch.step(a)
    with pytest.raises(ValueError, match="required"):
        batch.step()


def test_cornered_episodes_terminate_and_infos_carry_the_cornered_step():
    """docs/world-and-laws.md §1.7 through the batch and the ParallelEnv: with capture.cornered a cornered target
    terminates its world with outcome code 4 (``cornered``), its ``capture_step`` and
    ``cornered_step`` both that step; ``infos[agent]["cornered_step"]`` is an int (−1 until a
    target is cornered) at every step."""
    sets = {"policies.wolves": "bvc", "capture.cornered": True}
    batch = wolfpack.BatchEnv(num_envs=8, learners="none", seed=0, autoreset=False, **sets)
    batch.reset(0)
    out = batch.step()
    while (out["outcome"] == 0).any():
        out = batch.step()
    assert wolfpack.batch.OUTCOMES[4] == "cornered"
    ended = np.flatnonzero(out["outcome"] == 4)
    assert ended.size > 0
    assert out["terminated"][ended].all() and not out["truncated"][ended].any()
    assert (out["cornered_step"][ended, 0] == out["steps"][ended]).all()
    assert (out["capture_step"][ended, 0] == out["steps"][ended]).all()
    seed = int(ended[0])  # world e is seeded 0 + e
    env = wolfpack.parallel_env(learners="wolves", **{**sets, "env.action_mode": "velocity"})
    env.reset(seed=seed)
    seen = []
    while env.agents:
        _, _, _, _, infos = env.step(env.unwrapped.expert_actions())
        seen.append(infos["wolf_0"])
    assert all(type(i["cornered_step"]) is int for i in seen)
    assert seen[0]["cornered_step"] == -1
    if wolfpack.OUTCOMES[seen[-1]["outcome"]] == "cornered":  # the expert replays the law to float32 rounding
        assert seen[-1]["cornered_step"] == seen[-1]["capture_step"] == len(seen)


def test_help_shows_the_environment_specification():
    """help(wolfpack.parallel_env) and help(wolfpack.make_vec_env) show the specification, not a
    one-line wrapper docstring (the functions hide their modules of the same name)."""
    import pydoc

    text = pydoc.render_doc(wolfpack.parallel_env)
    for needle in ("Observation Space", "Rewards", "Termination", "seed000", "bvc", "formation", "shared_space"):
        assert needle in text, needle
    assert "Sizing PPO" in pydoc.render_doc(wolfpack.make_vec_env)
