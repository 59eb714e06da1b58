"""The one step path: ``wolfpack.BatchEnv.step`` into new arrays or into the caller's own
(``out=``, from ``new_outputs()``), and the SB3 VecEnv on top of it.

Into the caller's buffers or into fresh ones, the outputs are the same bit for bit, in the same
dtypes, shapes and layouts, whatever the buffers held before; actions that are not float32
C-contiguous arrays are converted, with the same result; bad buffers are refused before
anything moves.
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


def poison(out: dict) -> None:
    """Fills every buffer with what a forgotten write would show: NaN, True, all ones."""
    for a in out.values():
        if a.dtype.kind == "f":
            a.fill(np.nan)
        elif a.dtype.kind == "b":
            a.fill(True)
        else:
            a.fill(np.iinfo(a.dtype).max)


def random_actions(rng, batch, learners):
    shapes = {"wolves": (batch.num_envs, batch.n_wolves, 2), "targets": (batch.num_envs, batch.n_targets, 2)}
    acts = {side: rng.uniform(-1, 1, shape).astype(np.float32) for side, shape in shapes.items() if learners in (side, "both")}
    return acts.get("wolves"), acts.get("targets")


@pytest.mark.parametrize("learners", ["wolves", "targets", "both", "none"])
@pytest.mark.parametrize("autoreset", [True, False])
def test_step_into_the_callers_buffers_equals_a_step_into_new_ones(learners, autoreset):
    """Over episodes that end (by timeout and collision), with and without autoreset and the
    state: every output written into poisoned buffers equals the fresh step's, and the dict
    returned holds the caller's own arrays."""
    kwargs = dict(num_envs=3, learners=learners, seed=4, autoreset=autoreset, with_state=learners == "both", **{"world.max_steps": 7})
    fresh, into = wolfpack.BatchEnv(**kwargs), wolfpack.BatchEnv(**kwargs)
    assert_same_output(fresh.reset(), into.reset(), "reset")
    out = into.new_outputs()
    assert set(out) == set(fresh.step(*random_actions(np.random.default_rng(0), fresh, learners)))
    into.step(*random_actions(np.random.default_rng(0), into, learners))
    rng = np.random.default_rng(2)
    ended = 0
    for t in range(16):
        wa, ta = random_actions(rng, fresh, learners)
        poison(out)
        got = into.step(wa, ta, out=out)
        assert all(got[k] is out[k] for k in out) and list(got) == list(out)
        want = fresh.step(wa, ta)
        assert_same_output(got, want, f"step {t}")
        ended += int((want["terminated"] | want["truncated"]).sum())
    assert ended > 0


def test_steps_without_out_return_new_arrays_and_with_out_reuse_the_callers():
    batch = wolfpack.BatchEnv(num_envs=2, seed=0)
    batch.reset()
    acts = np.zeros((2, batch.n_wolves, 2), np.float32)
    a, b = batch.step(acts), batch.step(acts)
    assert all(not np.shares_memory(a[k], b[k]) for k in a)
    out = batch.new_outputs()
    c = batch.step(acts, out=out)
    before = c["obs_wolves"].copy()
    d = batch.step(acts, out=out)
    assert d["obs_wolves"] is out["obs_wolves"] and not np.array_equal(out["obs_wolves"], before)


@pytest.mark.parametrize("learners", ["wolves", "targets", "both"])
def test_actions_not_float32_c_contiguous_are_converted(learners):
    """float64, Fortran-ordered and nested-list actions give what float32 C-contiguous ones give."""
    exact, other = (wolfpack.BatchEnv(num_envs=3, learners=learners, seed=4, **{"world.max_steps": 7}) for _ in range(2))
    assert_same_output(exact.reset(), other.reset(), "reset")
    rng = np.random.default_rng(2)
    convert = (lambda a: a.astype(np.float64), np.asfortranarray, lambda a: a.tolist())
    for t in range(12):
        wa, ta = random_actions(rng, exact, learners)
        out = exact.step(wa, ta)
        out_b = other.step(*(None if a is None else convert[t % 3](a) for a in (wa, ta)))
        assert_same_output(out, out_b, f"step {t}")


def test_bad_actions_name_the_side_and_move_nothing():
    batch = wolfpack.BatchEnv(num_envs=2, seed=0)
    batch.reset()
    good = np.zeros((2, batch.n_wolves, 2), np.float32)
    for wa, ta, match in (
        (None, None, "wolf actions are required: wolves are learners here"),
        (good.astype(np.int64), None, "wolf actions: actions must be floating point, got dtype int64"),
        (np.zeros((2, 4, 2), np.float32), None, r"wolf actions: expected shape \(2, 5, 2\), got \(2, 4, 2\)"),
        (good, np.zeros((2, 1, 2), np.float32), "target actions given, but the targets are not learners here"),
        (np.full((2, 5, 2), np.nan, np.float32), None, "action of wolf_0 in world 0 is not finite"),
    ):
        with pytest.raises(ValueError, match=match):
            batch.step(wa, ta)
        assert batch.world_state(0)["step"] == 0
    batch.step(good)
    assert batch.world_state(0)["step"] == 1


def test_bad_buffers_name_the_key_and_move_nothing():
    batch = wolfpack.BatchEnv(num_envs=2, seed=0)
    batch.reset()
    acts = np.zeros((2, batch.n_wolves, 2), np.float32)

    def without(key):
        out = batch.new_outputs()
        del out[key]
        return out

    def changed(key, value):
        out = batch.new_outputs()
        out[key] = value(out[key])
        return out

    def read_only(key):
        out = batch.new_outputs()
        out[key].flags.writeable = False
        return out

    def twice(key, other):
        out = batch.new_outputs()
        out[other] = out[key]
        return out

    for out, match in (
        (without("obs_wolves"), r"out\['obs_wolves'\]: .* got no such key"),
        (changed("rewards_wolves", lambda a: a.astype(np.float64)), r"out\['rewards_wolves'\]: .*float32 .*got an array of dtype float64"),
        (changed("energy", lambda a: a[:, :-1].copy()), r"out\['energy'\]: .*shape \(2, 6\).* got shape \(2, 5\)"),
        (changed("obs_wolves", np.asfortranarray), r"out\['obs_wolves'\]: .*non-contiguous"),
        (changed("steps", lambda a: [0, 0]), r"out\['steps'\]: .*got list"),
        (read_only("terminated"), r"out\['terminated'\]: .*read-only"),
        (twice("rewards_wolves", "obs_wolves"), r"out\['obs_wolves'\]: .*shape"),
        (twice("terminated", "truncated"), r"out\['truncated'\]: .*given for two keys"),
    ):
        with pytest.raises(ValueError, match=match):
            batch.step(acts, out=out)
        assert batch.world_state(0)["step"] == 0
    batch.step(acts, out=batch.new_outputs())
    assert batch.world_state(0)["step"] == 1


def test_step_into_buffers_with_a_learned_opponent():
    """The opponent's observations live in the buffers too (it acts from them) and are left
    out of what step returns; the steps equal those into new arrays."""
    opponent = lambda obs: np.tanh(obs[:, :2]).astype(np.float32)  # noqa: E731
    kwargs = dict(num_envs=3, seed=5, learners="wolves", opponent=opponent, **{"world.max_steps": 6})
    fresh, into = wolfpack.BatchEnv(**kwargs), wolfpack.BatchEnv(**kwargs)
    assert_same_output(fresh.reset(), into.reset(), "reset")
    out = into.new_outputs()
    assert "obs_targets" in out
    rng = np.random.default_rng(3)
    for t in range(10):
        wa, _ = random_actions(rng, fresh, "wolves")
        got, want = into.step(wa, out=out), fresh.step(wa)
        assert "obs_targets" not in got and "final_obs_targets" not in got
        assert_same_output(got, want, f"step {t}")


@pytest.mark.parametrize("learners", ["wolves", "targets", "both"])
def test_vec_env_step_is_the_batch_step_in_slots(learners):
    """The VecEnv's observations, rewards, dones, infos (terminal observations included) and
    step_infos are a twin BatchEnv's step laid out per slot, in new arrays every step, also for
    float64 and non-contiguous actions, over episodes that end by timeout and by collision."""
    kwargs = dict(num_envs=3, learners=learners, seed=11, shared_space=learners == "both", **{"world.max_steps": 9})
    venv, twin = wolfpack.make_vec_env(**kwargs), wolfpack.make_vec_env(**kwargs)
    np.testing.assert_array_equal(venv.reset(), twin.reset())
    batch, per, n = twin.batch, venv.per_world, venv.batch.n_wolves
    rng = np.random.default_rng(1)
    ended = 0
    seen = []
    for t in range(40):
        a = rng.uniform(-1, 1, (venv.num_envs, 2))
        a = a if t % 3 == 0 else np.asfortranarray(a) if t % 3 == 1 else a.astype(np.float32)
        obs, rewards, dones, infos = venv.step(a)
        w = a.reshape(venv.num_envs // per, per, 2)
        out = batch.step(w if learners == "wolves" else w[:, :n] if learners == "both" else None, w if learners == "targets" else w[:, n:] if learners == "both" else None)
        assert_same_array(obs, twin._obs(out), "obs")
        side_rewards = [out["rewards_wolves"]] * (learners != "targets") + [out["rewards_targets"]] * (learners != "wolves")
        assert_same_array(rewards, np.concatenate(side_rewards, axis=1).reshape(-1), "rewards")
        assert_same_array(dones, np.repeat(out["terminated"] | out["truncated"], per), "dones")
        assert rewards.dtype == np.float32 and dones.dtype == bool and obs.shape == (venv.num_envs, venv.observation_space.shape[0])
        for key, value in venv.step_infos.items():
            assert_same_array(value, out[key], f"step_infos {key}")
        final = twin._obs(out, "final_obs")
        for k, info in enumerate(infos):
            if not dones[k]:
                assert info is RUNNING_INFO
                continue
            ended += 1
            assert_same_array(info["terminal_observation"], final[k], "terminal_observation")
            assert info["TimeLimit.truncated"] == bool(out["truncated"][k // per] and not out["terminated"][k // per])
        seen.append((obs, obs.copy(), rewards, rewards.copy()))
    assert ended > 0
    # Every step's arrays are fresh: later steps changed none of them.
    for obs, obs_copy, rewards, rewards_copy in seen:
        np.testing.assert_array_equal(obs, obs_copy)
        np.testing.assert_array_equal(rewards, rewards_copy)
    assert not np.shares_memory(seen[-1][0], seen[-2][0])


@pytest.mark.parametrize("learners", ["wolves", "both"])
def test_vec_env_non_finite_action_names_the_slot_and_moves_nothing(learners):
    venv = wolfpack.make_vec_env(num_envs=2, learners=learners, shared_space=learners == "both")
    venv.reset()
    per = venv.num_envs // 2
    for dtype in (np.float32, np.float64):
        bad = np.zeros((venv.num_envs, 2), dtype)
        bad[per + per - 1, 0] = np.inf  # the last slot of world 1: a target with learners="both"
        agent = "target_0" if learners == "both" else "wolf_4"
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
