"""The TorchRL view of the batch (wolfpack.torchrl_env.WolfpackEnv) against the batch itself:
its specs (TorchRL's own check_env_specs), what "next" holds when an episode ends under the
batch's autoreset, resets, masks, determinism and bad input; and BatchEnv's final_state."""

from __future__ import annotations

import numpy as np
import pytest
import wolfpack

torchrl = pytest.importorskip("torchrl")
torch = pytest.importorskip("torch")
from torchrl.envs.utils import check_env_specs, step_mdp  # noqa: E402
from wolfpack.torchrl_env import WolfpackEnv  # noqa: E402


def fixed_actions(rng: np.random.Generator, e: int, k: int) -> np.ndarray:
    return rng.uniform(-1, 1, (e, k, 2)).astype(np.float32)


@pytest.mark.parametrize("learners", ["wolves", "targets", "both"])
def test_specs_pass_torchrls_check_for_every_learning_side(learners):
    env = WolfpackEnv(num_envs=4, learners=learners, **{"world.max_steps": 6})
    check_env_specs(env)  # steps through an episode end and its autoreset
    groups = {"wolves": ("wolves",), "targets": ("targets",), "both": ("wolves", "targets")}[learners]
    assert env.groups == groups
    td = env.rollout(20, break_when_any_done=False)
    assert td.batch_size == (4, 20)
    for side, k, d in (("wolves", 5, env.batch.wolf_obs_dim), ("targets", 1, env.batch.target_obs_dim)):
        if side in groups:
            assert td[side, "observation"].shape == (4, 20, k, d)
            assert td["next", side, "reward"].shape == (4, 20, k, 1)
            assert td["next", side, "done"].shape == (4, 20, k, 1)
            assert td[side, "mask"].shape == (4, 20, k)
    assert td["state"].shape == (4, 20, env.batch.state_dim)
    # max_steps 6: every world's episode is truncated at steps 6, 12 and 18 of the rollout.
    assert td["next", "truncated"][:, :, 0].sum().item() == 4 * 3


def test_next_holds_what_the_episode_ended_in_and_the_reset_the_fresh_start():
    # The same worlds, actions and seed in a BatchEnv without autoreset: each world's state and
    # observations after its last step are what "next" must hold when the episode ends.
    kw = dict(num_envs=3, learners="wolves", seed=11, **{"world.max_steps": 5})
    env = WolfpackEnv(**kw)
    twin = wolfpack.BatchEnv(autoreset=False, **kw)
    twin.reset(11)
    env.set_seed(11)
    td = env.reset()
    assert np.array_equal(td["wolves", "observation"].numpy(), twin.reset(11)["obs_wolves"])
    rng = np.random.default_rng(0)
    for t in range(1, 6):
        a = fixed_actions(rng, 3, 5)
        td["wolves", "action"] = torch.from_numpy(a)
        td = env.step(td)
        out = twin.step(a)
        assert np.array_equal(td["next", "wolves", "observation"].numpy(), out["obs_wolves"]), t
        assert np.array_equal(td["next", "state"].numpy(), twin.state()), t
        assert np.array_equal(td["next", "wolves", "reward"][..., 0].numpy(), out["rewards_wolves"]), t
        td = step_mdp(td)
    assert td["truncated"].all() and (td["outcome"] == wolfpack.OUTCOMES.index("timeout")).all()
    # The reset TorchRL asks for returns the episode the batch has already started.
    td["_reset"] = td["done"].clone()
    fresh = env.reset(td)
    assert not fresh["done"].any()
    assert (fresh["state"][:, -1] == 0).all(), "the clock of a fresh episode is 0"
    assert not np.array_equal(fresh["wolves", "observation"].numpy(), out["obs_wolves"])


def test_a_world_reset_in_the_middle_of_its_episode_starts_afresh_and_the_others_go_on():
    env = WolfpackEnv(num_envs=3, learners="wolves")
    td = env.reset()
    for _ in range(4):
        td = step_mdp(env.rand_step(td))
    assert (td["state"][:, -1] > 0).all()
    which = torch.tensor([[False], [True], [False]])
    td["_reset"] = which
    after = env.reset(td)
    clock = after["state"][:, -1]
    assert clock[1] == 0 and (clock[[0, 2]] > 0).all()
    assert torch.equal(after["wolves", "observation"][[0, 2]], td["wolves", "observation"][[0, 2]])


def test_a_captured_target_is_masked_until_its_episode_ends():
    # Two targets standing still against the scripted pack: one is caught before the other.
    env = WolfpackEnv(num_envs=4, learners="targets", task="two-targets-v1", seed=3)
    td = env.reset()
    seen = False
    for _ in range(400):
        td["targets", "action"] = torch.zeros(4, 2, 2)
        td = env.step(td)
        nxt = td["next"]
        mask, done = nxt["targets", "mask"], nxt["done"][:, 0]
        partly = (~mask).any(-1) & mask.any(-1) & ~done
        seen = seen or bool(partly.any())
        td = step_mdp(td)
        if done.any():
            td["_reset"] = nxt["done"].clone()
            td = env.reset(td)
            assert td["targets", "mask"][done].all(), "a fresh episode's targets all play"
    assert seen, "no world had one target caught while the other still played"


def test_same_seed_same_rollout_for_any_thread_count():
    def roll(threads):
        env = WolfpackEnv(num_envs=6, learners="both", threads=threads, **{"world.max_steps": 30})
        env.set_seed(5)
        torch.manual_seed(0)
        return env.rollout(70, break_when_any_done=False)

    a, b = roll(1), roll(2)
    for key in (("next", "wolves", "observation"), ("next", "targets", "reward"), ("next", "state"), ("next", "done"), ("targets", "mask")):
        assert torch.equal(a[key], b[key]), key


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="learners"):
        WolfpackEnv(learners="none")
    with pytest.raises(ValueError, match="num_envs"):
        WolfpackEnv(num_envs=0)
    with pytest.raises(TypeError, match="colour"):
        WolfpackEnv(colour=3)
    with pytest.raises(ValueError, match="world.wolves"):
        WolfpackEnv(**{"world.wolves": -1})


def test_batch_with_state_returns_the_state_and_the_final_state():
    env = wolfpack.BatchEnv(num_envs=2, **{"world.max_steps": 2})
    env.reset(0)
    plain = env.step(np.zeros((2, 5, 2), np.float32))
    assert "state" not in plain and "final_state" not in plain
    with pytest.raises(ValueError, match="with_state must be True or False"):
        wolfpack.BatchEnv(with_state="yes")
    env = wolfpack.BatchEnv(num_envs=2, with_state=True, **{"world.max_steps": 2})
    assert np.array_equal(env.reset(0)["state"], env.state())
    first = env.step(np.zeros((2, 5, 2), np.float32))
    assert np.array_equal(first["state"], env.state())
    assert first["final_state"].shape == (2, env.state_dim) and not first["final_state"].any()
    last = env.step(np.zeros((2, 5, 2), np.float32))
    assert last["truncated"].all() and (last["final_state"][:, -1] == 1.0).all(), "the clock at the step limit"
    assert (last["state"][:, -1] == 0).all() and np.array_equal(last["state"], env.state()), "already reset"
    kept = wolfpack.BatchEnv(num_envs=2, autoreset=False, with_state=True)
    out = kept.step(np.zeros((2, 5, 2), np.float32))
    assert "final_state" not in out and np.array_equal(out["state"], kept.state())


def test_the_cheap_step_and_reset_builds_what_torchrls_generic_one_builds():
    # TorchRL's own step_and_maybe_reset (a step, step_mdp, then a partial reset merged entry by
    # entry) on one batch, the view's on a twin: the same tensordicts, step after step, through
    # many episode ends.
    from torchrl.envs import EnvBase

    def make():
        env = WolfpackEnv(num_envs=8, learners="both", **{"world.max_steps": 7})
        env.set_seed(2)
        return env, env.reset()

    (generic, a), (cheap, b) = make(), make()
    rng = np.random.default_rng(1)
    ended = 0
    for t in range(40):
        acts = {"wolves": torch.from_numpy(fixed_actions(rng, 8, 5)), "targets": torch.from_numpy(fixed_actions(rng, 8, 1))}
        for td in (a, b):
            for side, act in acts.items():
                td[side, "action"] = act
        da, a = EnvBase.step_and_maybe_reset(generic, a)
        db, b = cheap.step_and_maybe_reset(b)
        ended += int(da["next", "done"].sum())
        assert set(da.keys(True, True)) == set(db.keys(True, True)), t
        assert set(a.keys(True, True)) == set(b.keys(True, True)), t
        for key in da.keys(True, True):
            assert torch.equal(da[key], db[key]), (t, key)
        for key in a.keys(True, True):
            assert torch.equal(a[key], b[key]), (t, key)
    assert ended >= 8 * 5


def test_a_bad_seed_is_refused_and_the_seed_before_it_kept():
    env = WolfpackEnv(num_envs=2, seed=0)
    env.set_seed(7)
    for bad, error in ((2**64, ValueError), (-5, ValueError), (2**64 - 1, ValueError), (1.5, TypeError), (True, TypeError)):
        with pytest.raises(error, match="seed"):
            env.set_seed(bad)  # world i takes seed + i: 2**64 - 1 + 1 is no seed either
    first = env.reset()
    again = WolfpackEnv(num_envs=2, seed=0)
    again.set_seed(7)
    torch.testing.assert_close(first["wolves", "observation"], again.reset()["wolves", "observation"])


def test_a_step_without_the_action_is_a_key_error_naming_it():
    env = WolfpackEnv(num_envs=2, learners="both")
    td = env.reset()
    td["wolves", "action"] = torch.zeros(2, 5, 2)
    with pytest.raises(KeyError, match=r"no \('targets', 'action'\) entry"):
        env.step(td)


def test_a_bad_device_is_refused_before_the_batch_is_built():
    with pytest.raises(ValueError, match="device: 'tpu' is not a torch device"):
        WolfpackEnv(device="tpu")
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="no CUDA device here"):
            WolfpackEnv(device="cuda")
