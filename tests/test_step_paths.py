"""The fast step paths of the batch interfaces against their checked ones.

``wolfpack.BatchEnv.step`` hands actions that are exactly what the core takes straight to it
(``_core.BatchEnv.try_step``) and checks and converts anything else; the SB3 VecEnv steps in
one call (``_core.BatchEnv.step_slots``) unless a learned opponent acts from Python, when it
goes through ``BatchEnv.step``. Every path must give the same outputs, bit for bit, in the
same dtypes, shapes and layouts, and fresh arrays every step.
"""

from __future__ import annotations

import numpy as np
import pytest
import wolfpack
from wolfpack.vec_env import RUNNING_INFO


def assert_same_array(a: np.ndarray, b: np.ndarray, what: str) -> None:
    assert type(a) is np.ndarray and type(b) is np.ndarray, what
    assert a.dtype == b.dtype and a.shape == b.shape, (what, a.dtype, b.dtype, a.shape, b.shape)
    assert a.flags.c_contiguous and b.flags.c_contiguous and a.flags.writeable and b.flags.writeable, what
    np.testing.assert_array_equal(a, b, err_msg=what)


def assert_same_output(a: dict, b: dict, what: str) -> None:
    assert list(a) == list(b), what
    for k in a:
        assert_same_array(a[k], b[k], f"{what}: {k}")


def through_batch(venv, actions):
    """One step of ``venv`` through BatchEnv.step (the path of a learned opponent)."""
    venv.step_async(actions)
    pending, venv._actions = venv._actions, None
    return venv._step_through_batch(pending)


@pytest.mark.parametrize("learners", ["wolves", "targets", "all"])
def test_vec_env_one_call_step_equals_the_batch_path(learners):
    """Same observations, rewards, dones, infos (terminal observations included) and
    step_infos from the one-call path as through BatchEnv.step, also for float64 and
    non-contiguous actions, over episodes that end by timeout and by collision."""
    kwargs = dict(num_envs=3, learners=learners, seed=11, shared_space=learners == "all", **{"world.max_steps": 9})
    fast, slow = wolfpack.make_vec_env(**kwargs), wolfpack.make_vec_env(**kwargs)
    np.testing.assert_array_equal(fast.reset(), slow.reset())
    rng = np.random.default_rng(1)
    ended = 0
    seen = []
    for t in range(40):
        a = rng.uniform(-1, 1, (fast.num_envs, 2))
        a = a if t % 3 == 0 else np.asfortranarray(a) if t % 3 == 1 else a.astype(np.float32)
        obs, rewards, dones, infos = fast.step(a)
        obs_b, rewards_b, dones_b, infos_b = through_batch(slow, a)
        assert_same_array(obs, obs_b, "obs")
        assert_same_array(rewards, rewards_b, "rewards")
        assert_same_array(dones, dones_b, "dones")
        assert rewards.dtype == np.float32 and dones.dtype == bool and obs.shape == (fast.num_envs, fast.observation_space.shape[0])
        assert_same_output(fast.step_infos, slow.step_infos, "step_infos")
        assert len(infos) == len(infos_b) == fast.num_envs
        for k, (i, j) in enumerate(zip(infos, infos_b)):
            if not dones[k]:
                assert i is RUNNING_INFO and j is RUNNING_INFO
                continue
            ended += 1
            assert list(i) == list(j)
            for key in i:
                if key == "terminal_observation":
                    assert_same_array(i[key], j[key], "terminal_observation")
                else:
                    assert i[key] == j[key] and type(i[key]) is type(j[key]), key
        seen.append((obs, obs.copy(), rewards, rewards.copy()))
    assert ended > 0
    # Every step's arrays are fresh: later steps changed none of them.
    for obs, obs_copy, rewards, rewards_copy in seen:
        np.testing.assert_array_equal(obs, obs_copy)
        np.testing.assert_array_equal(rewards, rewards_copy)
    assert not np.shares_memory(seen[-1][0], seen[-2][0])


@pytest.mark.parametrize("learners", ["wolves", "all"])
def test_vec_env_non_finite_action_names_the_slot_and_moves_nothing(learners):
    venv = wolfpack.make_vec_env(num_envs=2, learners=learners, shared_space=learners == "all")
    venv.reset()
    per = venv.num_envs // 2
    for dtype in (np.float32, np.float64):
        bad = np.zeros((venv.num_envs, 2), dtype)
        bad[per + per - 1, 0] = np.inf  # the last slot of world 1: a target with learners="all"
        agent = "target_0" if learners == "all" else "wolf_4"
        with pytest.raises(ValueError, match=f"slot {2 * per - 1} \\({agent} in world 1\\) is not finite"):
            venv.step(bad)
        assert [venv.batch.world_state(e)["step"] for e in range(2)] == [0, 0]
    venv.step(np.zeros((venv.num_envs, 2), np.float32))
    assert [venv.batch.world_state(e)["step"] for e in range(2)] == [1, 1]


def test_vec_env_non_finite_action_with_a_learned_opponent():
    venv = wolfpack.make_vec_env(num_envs=2, opponent=lambda obs: np.zeros((len(obs), 2), np.float32))
    venv.reset()
    bad = np.zeros((10, 2), np.float32)
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="slot 3 \\(wolf_3 in world 0\\) is not finite"):
        venv.step(bad)
    assert venv.batch.world_state(0)["step"] == 0


@pytest.mark.parametrize("learners", ["wolves", "targets", "all", "none"])
def test_batch_fast_and_checked_step_paths_agree(learners):
    """float32 C-contiguous actions take the core's fast path; float64 and non-contiguous ones
    are converted first: the outputs are the same either way."""
    fast, slow = (wolfpack.BatchEnv(num_envs=3, learners=learners, seed=4, **{"world.max_steps": 7}) for _ in range(2))
    assert_same_output(fast.reset(), slow.reset(), "reset")
    rng = np.random.default_rng(2)
    shapes = {"wolves": (3, fast.n_wolves, 2), "targets": (3, fast.n_targets, 2)}
    for t in range(12):
        acts = {side: rng.uniform(-1, 1, shape).astype(np.float32) for side, shape in shapes.items() if learners in (side, "all")}
        wa, ta = acts.get("wolves"), acts.get("targets")
        other = (lambda a: a.astype(np.float64)) if t % 2 else (lambda a: np.asfortranarray(a))
        out = fast.step(wa, ta)
        out_b = slow.step(*(None if a is None else other(a) for a in (wa, ta)))
        assert_same_output(out, out_b, f"step {t}")


def test_batch_core_try_step_declines_inexact_actions_without_moving():
    batch = wolfpack.BatchEnv(num_envs=2, seed=0)
    batch.reset()
    core = batch._core
    good = np.zeros((2, 5, 2), np.float32)
    for wa, ta in (
        (good.astype(np.float64), None),
        (np.asfortranarray(np.zeros((2, 5, 2), np.float32)), None),
        (np.zeros((2, 4, 2), np.float32), None),
        (good.tolist(), None),
        (None, None),
        (good, np.zeros((2, 1, 2), np.float32)),
    ):
        assert core.try_step(wa, ta) is None
    assert batch.world_state(0)["step"] == 0
    assert core.step_slots(np.zeros((10, 2), np.float64)) is None and core.step_slots(np.zeros((9, 2), np.float32)) is None
    assert batch.world_state(0)["step"] == 0
    assert set(core.try_step(good)) >= {"obs_wolves", "rewards_wolves"} and batch.world_state(0)["step"] == 1
