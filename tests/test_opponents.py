"""Learned and scripted opponents inside the batch (wolfpack.opponents): a model opponent
reproduces the model's own evaluation bit for bit, each side reads its actions in its own mode,
swapping keeps the worlds, determinism over threads, sampled opponents repeat, and bad
opponents are named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import wolfpack
from wolfpack import BatchEnv, Opponent

sb3 = pytest.importorskip("stable_baselines3")

MODELS = Path(__file__).resolve().parents[1] / "results" / "models"
WOLF_MODEL = MODELS / "wolves_ft"  # PPO, velocity mode
TARGET_MODEL = MODELS / "escape_ppo"  # PPO, unicycle mode


@pytest.fixture(scope="module")
def wolf_model():
    return sb3.PPO.load(WOLF_MODEL / "model.zip", device="cpu")


@pytest.fixture(scope="module")
def target_model():
    return sb3.PPO.load(TARGET_MODEL / "model.zip", device="cpu")


def act(model, obs: np.ndarray) -> np.ndarray:
    """The model's deterministic actions for [E, K, D] observations, as the learner's side."""
    e, k, d = obs.shape
    a, _ = model.predict(obs.reshape(e * k, d), deterministic=True)
    return np.asarray(a, np.float32).reshape(e, k, 2)


def episode_numbers(out: dict) -> list:
    return [out[k].tolist() for k in ("outcome", "steps", "capture_step", "energy", "collisions", "distance")]


def run_to_end(batch: BatchEnv, wolves=None, targets=None, seed: int = 0) -> tuple[list, list]:
    """Runs every world's first episode (no autoreset); (final numbers, per-step rewards)."""
    out = batch.reset(seed)
    rewards = []
    while True:
        wa = act(wolves, out["obs_wolves"]) if wolves is not None else None
        ta = act(targets, out["obs_targets"]) if targets is not None else None
        out = batch.step(wa, ta)
        rewards.append((out["rewards_wolves"].tobytes(), out["rewards_targets"].tobytes()))
        if (out["outcome"] != 0).all():
            return episode_numbers(out), rewards


def test_a_model_opponent_reproduces_the_models_own_evaluation(target_model):
    # escape_ppo evaluated as a learner (its own evaluation: learners="targets", the model
    # acting in the test) == escape_ppo as the opponent of scripted wolves (learners="none"),
    # bit for bit, on the model's own params.
    params = Opponent(str(TARGET_MODEL)).config["params"]
    own = run_to_end(BatchEnv(params, num_envs=12, learners="targets", autoreset=False, threads=1), targets=target_model)
    as_opponent = run_to_end(BatchEnv(params, num_envs=12, learners="none", autoreset=False, threads=1, opponent=str(TARGET_MODEL)))
    assert own == as_opponent
    # ... and not by accident: the scripted escape law plays differently.
    assert run_to_end(BatchEnv(params, num_envs=12, learners="none", autoreset=False, threads=1))[0] != own[0]


def test_each_model_acts_in_its_own_action_mode(wolf_model, target_model):
    # wolves_ft (velocity mode) against escape_ppo (unicycle): the opponent path equals both
    # models driven as learners with the wolves' mode set by hand, and differs from reading the
    # wolves' actions in unicycle mode.
    params = wolfpack.load_params()
    by_hand = {**params, "env": {**params["env"], "wolf_action_mode": "velocity"}}
    want = run_to_end(BatchEnv(by_hand, num_envs=10, learners="both", autoreset=False, threads=1), wolves=wolf_model, targets=target_model)
    got = run_to_end(BatchEnv(params, num_envs=10, learners="targets", autoreset=False, threads=1, opponent=str(WOLF_MODEL)), targets=target_model)
    assert got == want
    wrong_mode = run_to_end(BatchEnv(params, num_envs=10, learners="targets", autoreset=False, threads=1, opponent=Opponent(str(WOLF_MODEL), action_mode="unicycle")), targets=target_model)
    assert wrong_mode[0] != want[0]


def test_opponents_as_objects_and_callables_drive_the_same_way(wolf_model):
    # The path brings the model's velocity mode; the others read it from the params.
    params = wolfpack.load_params(overrides={"env.wolf_action_mode": "velocity"})
    runs = [
        run_to_end(BatchEnv(params, num_envs=6, learners="targets", autoreset=False, threads=1, opponent=o), targets=_still())
        for o in (str(WOLF_MODEL), wolf_model, wolf_model.policy, lambda obs: wolf_model.predict(obs, deterministic=True)[0])
    ]
    assert all(r == runs[0] for r in runs[1:])


class _still:
    """A stand-in target 'model' for run_to_end: stands still (unicycle: v = 0, ω = 0)."""

    def predict(self, obs, deterministic=True):
        a = np.zeros((len(obs), 2), np.float32)
        a[:, 0] = -1.0
        return a, None


def rollout_bits(batch: BatchEnv, steps: int, swap_at: int | None = None, swap_to=None) -> list[bytes]:
    """``steps`` autoreset steps with fixed random learner actions; with ``swap_at`` the
    opponent becomes ``swap_to`` before that step."""
    rng = np.random.default_rng(5)
    batch.reset(3)
    bits = []
    for t in range(steps):
        if t == swap_at:
            batch.set_opponent(swap_to)
        ta = rng.uniform(-1, 1, (batch.num_envs, batch.n_targets, 2)).astype(np.float32)
        out = batch.step(None, ta)
        bits.append(b"".join(np.ascontiguousarray(out[k]).tobytes() for k in sorted(out)))
    return bits


def test_a_deterministic_opponent_is_bit_identical_for_any_thread_count(wolf_model):
    runs = [rollout_bits(BatchEnv(num_envs=37, learners="targets", seed=3, threads=t, opponent=wolf_model, **{"env.action_mode": "velocity"}), 330) for t in (1, 2, 3)]
    assert runs[0] == runs[1] == runs[2]


def test_swapping_the_opponent_keeps_the_worlds(wolf_model):
    model = lambda obs: wolf_model.predict(obs, deterministic=True)[0]  # noqa: E731
    calls = {"n": 0}

    def scripted_then_model(obs):
        # One callable that is 'still' for 40 calls, then the model: the reference for a swap at step 40.
        calls["n"] += 1
        if calls["n"] <= 40:
            a = np.zeros((len(obs), 2), np.float32)
            a[:, 0] = -1.0
            return a
        return model(obs)

    still = lambda obs: np.tile(np.array([[-1.0, 0.0]], np.float32), (len(obs), 1))  # noqa: E731
    kw = dict(num_envs=5, learners="targets", seed=3, threads=1)
    swapped = rollout_bits(BatchEnv(opponent=still, **kw), 320, swap_at=40, swap_to=model)
    assert swapped == rollout_bits(BatchEnv(opponent=scripted_then_model, **kw), 320)
    # A scripted law swapped in before the first step is that law built in; the same opponent
    # again changes nothing; a law swapped in mid-episode takes over without resetting a world.
    assert rollout_bits(BatchEnv(opponent=model, **kw), 200, swap_at=0, swap_to="bvc") == rollout_bits(BatchEnv(opponent="bvc", **kw), 200)
    assert rollout_bits(BatchEnv(opponent="bvc", **kw), 200, swap_at=0, swap_to=model) == rollout_bits(BatchEnv(opponent=model, **kw), 200)
    assert rollout_bits(BatchEnv(opponent="bvc", **kw), 200, swap_at=50, swap_to="bvc") == rollout_bits(BatchEnv(opponent="bvc", **kw), 200)
    b = BatchEnv(opponent="seed000", **kw)
    b.reset(3)
    for _ in range(30):
        b.step(None, np.zeros((5, 1, 2), np.float32))
    b.set_opponent(model)
    out = b.step(None, np.zeros((5, 1, 2), np.float32))
    assert (out["steps"] == 31).all() and b.params["env"]["wolf_action_mode"] is None
    b.set_opponent(None)
    assert b.opponent is None and b.params["policies"]["wolves"] == "seed000"


def test_sampled_opponents_repeat_with_their_seed(wolf_model):
    kw = dict(num_envs=4, learners="targets", seed=3, threads=1, **{"env.action_mode": "velocity"})
    one = rollout_bits(BatchEnv(opponent=Opponent(wolf_model, deterministic=False, seed=1), **kw), 60)
    assert one == rollout_bits(BatchEnv(opponent=Opponent(wolf_model, deterministic=False, seed=1), **kw), 60)
    assert one != rollout_bits(BatchEnv(opponent=Opponent(wolf_model, deterministic=False, seed=2), **kw), 60)
    assert one != rollout_bits(BatchEnv(opponent=Opponent(wolf_model), **kw), 60)


def test_sb3_trains_against_an_opponent_and_swaps_it_through_vec_monitor(wolf_model):
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecMonitor

    pool = ["seed000", "bvc", wolf_model.policy]
    seen = []

    class Swap(BaseCallback):
        def _on_rollout_start(self) -> None:
            self.training_env.set_opponent(pool[len(seen) % len(pool)])
            seen.append(self.training_env.opponent.name)

        def _on_step(self) -> bool:
            return True

    venv = VecMonitor(wolfpack.make_vec_env(num_envs=4, learners="targets", seed=1, threads=1, opponent="seed000", **{"env.wolf_action_mode": "velocity"}))
    model = PPO("MlpPolicy", venv, n_steps=16, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(3 * 64, callback=Swap())
    assert seen == ["seed000", "bvc", "ActorCriticPolicy"] and venv.venv.opponent.kind == "model"


def test_a_parallel_env_with_an_opponent_passes_pettingzoos_api_test(wolf_model):
    from pettingzoo.test import parallel_api_test

    env = wolfpack.parallel_env(learners="targets", opponent=lambda obs: wolf_model.predict(obs, deterministic=True)[0], **{"env.wolf_action_mode": "velocity", "world.max_steps": 60})
    parallel_api_test(env, num_cycles=80)
    assert env.possible_agents == ["target_0"]


class _FakeModel:
    def __init__(self, obs: int, act: int) -> None:
        from gymnasium import spaces

        self.observation_space = spaces.Box(-1, 1, (obs,))
        self.action_space = spaces.Box(-1, 1, (act,))

    def predict(self, obs, deterministic=True):
        return np.zeros((len(obs), self.action_space.shape[0]), np.float32), None


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(learners="wolves", opponent=str(WOLF_MODEL)), ["wolves_ft", "drives the wolves", "learn"]),
        (dict(learners="targets", opponent="escape"), ["'escape'", "targets", "learn"]),
        (dict(learners="both", opponent="bvc"), ["learners='both'"]),
        (dict(learners="none", opponent=lambda o: o), ["learners='none'", "side"]),
        (dict(learners="targets", opponent=_FakeModel(49, 2)), ["49", "50"]),
        (dict(learners="targets", opponent=_FakeModel(50, 3)), ["shape (3,)", "2 entries"]),
        (dict(learners="targets", opponent="no/such/model"), ["no/such/model", "no model file"]),
        (dict(learners="targets", opponent=str(WOLF_MODEL), **{"env.lidar.rays": 8}), ["50", "42"]),
    ],
)
def test_bad_opponents_are_value_errors_naming_what_is_wrong(kwargs, words):
    with pytest.raises(ValueError) as e:
        BatchEnv(num_envs=2, **kwargs)
    for w in words:
        assert w in str(e.value), str(e.value)


@pytest.mark.parametrize(
    "fn, words",
    [
        (lambda obs: np.full((len(obs), 2), np.nan), ["'bad'", "non-finite"]),
        (lambda obs: np.zeros((len(obs), 3)), ["'bad'", "(10, 3)", "(10, 2)"]),
        (lambda obs: np.zeros(2), ["'bad'", "shape (2,)"]),
        (lambda obs: [["a", "b"]] * len(obs), ["'bad'", "dtype"]),
    ],
)
def test_a_callable_returning_nonsense_is_named(fn, words):
    b = BatchEnv(num_envs=2, learners="targets", opponent=Opponent(fn, name="bad"))
    b.reset()
    before = b.world_state(0)["wolves"].copy()
    with pytest.raises(ValueError) as e:
        b.step(None, np.zeros((2, 1, 2), np.float32))
    for w in words:
        assert w in str(e.value), str(e.value)
    assert (b.world_state(0)["wolves"] == before).all(), "a bad opponent moved nothing"


def test_an_opponent_of_the_wrong_kind_is_a_type_error():
    with pytest.raises(TypeError, match="opponent must be"):
        BatchEnv(num_envs=1, learners="targets", opponent=3)
