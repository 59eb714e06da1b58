"""wolfpack inside other training stacks, through the libraries' own entry points (no shims of
ours in between): Gymnasium's vector envs and wrappers, PettingZoo's state and max-cycles tests,
and the type stability of infos that libraries which stack them rely on."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
import wolfpack
from pettingzoo.test import api_test, max_cycles_test, state_test

INFO_TYPES = {"outcome": int, "capture_step": int, "cornered_step": int, "energy": float, "collisions": int, "distance": float}


def test_parallel_env_infos_keep_one_numeric_type_per_key_for_the_whole_episode():
    """Every info value is a number of the same type from reset to the end (capture_step once
    was None until a capture and outcome a string, which Gymnasium's vector envs
    and TorchRL cannot stack)."""
    env = wolfpack.parallel_env(learners="both", **{"policies.wolves": "seed000"})
    for seed in (0, 3):
        _, infos = env.reset(seed=seed)
        seen = [infos]
        while env.agents:
            _, _, _, _, infos = env.step({a: env.action_space(a).sample() for a in env.agents})
            seen.append(infos)
        for step in seen:
            for agent, info in step.items():
                assert {k: type(v) for k, v in info.items()} == INFO_TYPES, (seed, agent, info)
        assert wolfpack.OUTCOMES[next(iter(seen[-1].values()))["outcome"]] != "running"
    assert wolfpack.OUTCOMES == ("running", "captured", "collision", "timeout", "cornered")


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_gymnasium_make_vec_with_episode_statistics_and_observation_normalisation(mode):
    """``gymnasium.make_vec`` (sync and async) with Gymnasium's own vector wrappers, run past
    several episode ends (same-step autoreset of the vector env)."""
    envs = gymnasium.make_vec("wolfpack/Escape-v0", num_envs=3, vectorization_mode=mode, vector_kwargs={"autoreset_mode": gymnasium.vector.AutoresetMode.NEXT_STEP}, **{"world.max_steps": 25})
    envs = gymnasium.wrappers.vector.RecordEpisodeStatistics(envs)
    envs = gymnasium.wrappers.vector.NormalizeObservation(envs)
    try:
        obs, infos = envs.reset(seed=0)
        assert obs.shape == (3, 51) and obs.dtype == np.float32
        episodes = 0
        for _ in range(60):
            obs, rewards, terminated, truncated, infos = envs.step(envs.action_space.sample())
            assert np.isfinite(obs).all() and np.isfinite(rewards).all()
            for key, kind in INFO_TYPES.items():
                assert infos[key].shape == (3,) and np.issubdtype(infos[key].dtype, np.integer if kind is int else np.floating), key
            if "episode" in infos:
                done = infos["_episode"]
                episodes += int(done.sum())
                assert (infos["episode"]["l"][done] <= 25).all()
        assert episodes >= 3
    finally:
        envs.close()


def test_pettingzoo_state_and_max_cycles_tests():
    """PettingZoo's own ``state_test`` (state_space, state() of the AEC and the parallel env)
    and ``max_cycles_test`` (PettingZoo's ``max_cycles`` keyword is world.max_steps), with the
    AEC env ``wolfpack.env``."""
    state_test(wolfpack.env(learners="both"), wolfpack.parallel_env(learners="both"))
    max_cycles_test(wolfpack)
    api_test(wolfpack.env(learners="both"), num_cycles=30)


def test_state_layout_and_bad_use():
    """The global state: fixed size 6N + 7M + 5K + 1 for fixed params, inside state_space, one
    row per world from the batch and the VecEnv, the same row the ParallelEnv gives; a clear
    error before reset."""
    env = wolfpack.parallel_env(learners="wolves")
    with pytest.raises(RuntimeError, match="reset"):
        env.state()
    env.reset(seed=5)
    s = env.state()
    assert s.shape == env.state_space.shape == (6 * 5 + 7 * 1 + 5 * 12 + 1,)
    assert env.state_space.contains(s)
    w = env.unwrapped.world_state()
    np.testing.assert_allclose(s[:2], w["wolves"][0, :2] / 10.0, atol=1e-6)  # x̂, ŷ of wolf 0
    np.testing.assert_allclose(s[2:4], [np.cos(w["wolves"][0, 2]), np.sin(w["wolves"][0, 2])], atol=1e-6)
    assert s[-1] == 0.0  # the clock at reset
    env.step(env.unwrapped.expert_actions())
    assert env.state()[-1] == pytest.approx(1 / 300)
    batch = wolfpack.BatchEnv(num_envs=3, seed=5)
    with pytest.raises(RuntimeError, match=r"call reset\(\) before state\(\)"):
        batch.state()  # the worlds exist, but state() waits for a reset as every env's does
    venv_before = wolfpack.make_vec_env(num_envs=3, seed=5)
    with pytest.raises(RuntimeError, match=r"call reset\(\) before state\(\)"):
        venv_before.state()
    batch.reset(5)
    assert batch.state().shape == (3, batch.state_dim)
    fresh = wolfpack.parallel_env()
    fresh.reset(seed=5)
    np.testing.assert_array_equal(batch.state()[0], fresh.state())  # world 0 of the batch is seeded 5
    venv = wolfpack.make_vec_env(num_envs=3, seed=5)
    venv.reset()
    np.testing.assert_array_equal(venv.state(), batch.state())
    # A layout with fewer obstacles than the params leaves empty slots.
    from conftest import layout_dict

    env.reset(seed=1, options={"layout": layout_dict()})
    s = env.state()
    present = s[6 * 5 + 7 : 6 * 5 + 7 + 5 * 12 : 5]
    assert present.tolist() == [1.0, 1.0] + [0.0] * 10


# --- one observation space for both sides ---------------------------------------------------


def test_shared_space_layout_and_bad_use():
    env = wolfpack.parallel_env(learners="both", shared_space=True)
    obs, _ = env.reset(seed=2)
    plain = wolfpack.parallel_env(learners="both")
    ref, _ = plain.reset(seed=2)
    n, m = 5, 1
    dim = 2 + n + m + 51
    assert {env.observation_space(a).shape for a in env.possible_agents} == {(dim,)}
    for k, a in enumerate(env.possible_agents):
        o = obs[a]
        assert env.observation_space(a).contains(o)
        assert o[:2].tolist() == ([1.0, 0.0] if a.startswith("wolf") else [0.0, 1.0])  # side flag
        assert np.flatnonzero(o[2 : 2 + n + m]).tolist() == [k]  # agent one-hot
        native = ref[a]
        np.testing.assert_array_equal(o[2 + n + m : 2 + n + m + len(native)], native)
        assert not o[2 + n + m + len(native) :].any()  # zero padding (wolves: 50 of 51)
    with pytest.raises(ValueError, match="shared_space"):
        wolfpack.parallel_env(learners="wolves", shared_space=True)
    with pytest.raises(ValueError, match="shared_space"):
        wolfpack.make_vec_env(num_envs=2, learners="targets", shared_space=True)
    with pytest.raises(ValueError, match="shared_space=True"):
        wolfpack.make_vec_env(num_envs=2, learners="both")


def test_make_vec_env_learners_all_matches_the_parallel_env():
    """``make_vec_env(learners="both", shared_space=True)``: N+M slots per world, wolves first,
    the ParallelEnv's shared observations and rewards; same-step autoreset keeps the final
    shared observation."""
    venv = wolfpack.make_vec_env(num_envs=2, learners="both", shared_space=True, seed=4, **{"world.max_steps": 6})
    env = wolfpack.parallel_env(learners="both", shared_space=True, seed=4, **{"world.max_steps": 6})
    obs = venv.reset()
    ref, _ = env.reset(seed=4)
    assert obs.shape == (12, env.observation_space("wolf_0").shape[0])
    np.testing.assert_array_equal(obs[:6], np.stack([ref[a] for a in env.possible_agents]))
    rng = np.random.default_rng(0)
    for t in range(6):
        actions = rng.uniform(-1, 1, (12, 2)).astype(np.float32)
        obs, rewards, dones, infos = venv.step(actions)
        ref, ref_rewards, _, _, _ = env.step({a: actions[k] for k, a in enumerate(env.possible_agents)})
        np.testing.assert_allclose(rewards[:6], [ref_rewards[a] for a in env.possible_agents], rtol=1e-6)
        if dones[0]:
            np.testing.assert_array_equal(infos[0]["terminal_observation"], ref["wolf_0"])
            break
        np.testing.assert_array_equal(obs[:6], np.stack([ref[a] for a in env.possible_agents]))
    assert dones[:6].all()
    assert infos[5]["outcome_name"] in ("timeout", "captured", "collision")


def test_supersuit_concat_vec_envs_trains_sb3_ppo_on_both_sides():
    """SuperSuit's own conversion of the ParallelEnv (learners="both", shared_space=True) into
    SB3 vector envs, and a few thousand steps of PPO with one policy for wolves and target."""
    import supersuit as ss
    from stable_baselines3 import PPO

    venv = ss.pettingzoo_env_to_vec_env_v1(wolfpack.parallel_env(learners="both", shared_space=True))
    venv = ss.concat_vec_envs_v1(venv, 2, num_cpus=0, base_class="stable_baselines3")
    assert venv.num_envs == 12
    # No seed=: SB3 would call venv.seed(), which SuperSuit 3.11's ConcatVecEnv lacks.
    model = PPO("MlpPolicy", venv, n_steps=128, batch_size=256, n_epochs=1, verbose=0)
    model.learn(3000)
    assert model.num_timesteps >= 3000
    venv.close()


# --- TorchRL (and through it BenchMARL) -------------------------------------------------------


def test_torchrl_pettingzoo_wrapper_checks_specs_and_rolls_out_grouped_per_side():
    pytest.importorskip("torchrl")
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper
    from torchrl.envs.utils import check_env_specs

    env = PettingZooWrapper(wolfpack.parallel_env(learners="both"), use_mask=True)
    assert set(env.group_map) == {"wolf", "target"}
    check_env_specs(env)
    td = env.rollout(100, break_when_any_done=False)  # resets finished episodes and goes on
    assert td.batch_size[0] == 100
    assert td["wolf", "observation"].shape == (100, 5, 50)
    assert td["target", "observation"].shape == (100, 1, 51)
    assert td["next", "wolf", "reward"].shape == (100, 5, 1)
    assert td["next", "wolf", "info", "outcome"].shape == (100, 5)


def test_torchrl_gym_env_on_escape_v0():
    pytest.importorskip("torchrl")
    from torchrl.envs.libs.gym import GymEnv
    from torchrl.envs.utils import check_env_specs

    env = GymEnv("wolfpack/Escape-v0")
    check_env_specs(env)
    td = env.rollout(50)
    assert td["observation"].shape[-1] == 51 and td.batch_size[0] <= 50
