"""``wolfpack dataset``: expert play recorded as offline datasets — Minari's format for the
single-learner view, the project's npz for the rest — and read back."""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import wolfpack
from wolfpack import dataset
from wolfpack.task import gym_id, task_params

ROOT = Path(__file__).resolve().parents[1]
WOLF_MODEL = ROOT / "results" / "models" / "wolves_ft"  # SB3, 5 wolves


def test_npz_holds_the_scripted_episodes_and_replays_bit_for_bit(tmp_path):
    meta = dataset.make("fast-target-v1", "bvc", tmp_path / "d", episodes=5, seed=3)
    assert (meta["format"], meta["side"], meta["files"]) == ("npz", "wolves", ["trajectories.npz"])
    assert json.loads((tmp_path / "d" / "dataset.json").read_text())["steps"] == meta["steps"]
    arrays = dataset.load_npz(tmp_path / "d")
    eps = list(dataset.episodes(arrays))
    # The scripted law's episodes: following its expert actions gives `wolfpack hunt`'s (on these
    # seeds exactly; a few in a thousand end at another step, the action encoding rounding the
    # law's command).
    scripted = wolfpack.run_episodes(task_params("fast-target-v1", {"policies.wolves": "bvc"}), 5, 3)
    assert [e["outcome"] for e in eps] == [r["outcome"] for r in scripted]
    assert [len(e["terminated"]) for e in eps] == [r["steps"] for r in scripted]
    assert sum(len(e["terminated"]) for e in eps) == meta["steps"] == arrays["episode_offsets"][-1]
    assert meta["outcomes"] == dict(Counter(r["outcome"] for r in scripted))
    # The size warned about is the per-step size times max_steps for every episode.
    per_step = sum(arrays[k].nbytes for k in ("obs_wolves", "obs_targets", "state", "actions_wolves", "actions_targets", "rewards_wolves", "rewards_targets", "terminated", "truncated"))
    assert dataset.upper_bound_bytes("fast-target-v1", 5) == per_step / meta["steps"] * 5 * 300
    # Replaying the recorded actions gives the recorded observations, rewards and endings.
    ep = eps[2]
    params = task_params("fast-target-v1", {"policies.wolves": "bvc"})
    batch = wolfpack.BatchEnv(params, num_envs=1, learners="both", seed=ep["seed"], autoreset=False)
    out = batch.reset(ep["seed"])
    for t in range(len(ep["terminated"])):
        assert np.array_equal(out["obs_wolves"][0], ep["obs_wolves"][t]) and np.array_equal(out["obs_targets"][0], ep["obs_targets"][t])
        assert np.array_equal(batch.state()[0], ep["state"][t])
        out = batch.step(ep["actions_wolves"][t][None], ep["actions_targets"][t][None])
        assert np.array_equal(out["rewards_wolves"][0], ep["rewards_wolves"][t])
        assert (out["terminated"][0], out["truncated"][0]) == (ep["terminated"][t], ep["truncated"][t])
    assert np.array_equal(out["obs_wolves"][0], ep["final_obs_wolves"])
    assert ep["terminated"][-1] or ep["truncated"][-1]
    assert not (ep["terminated"][:-1].any() or ep["truncated"][:-1].any())


def test_a_model_plays_its_side_in_the_npz(tmp_path):
    dataset.make("open-v1", str(WOLF_MODEL), tmp_path / "m", episodes=2, seed=0)
    arrays = dataset.load_npz(tmp_path / "m" / "trajectories.npz")
    model = wolfpack.Opponent(str(WOLF_MODEL), side="wolves")
    obs = arrays["obs_wolves"][:40]
    # The recording asked the model for one step of every world at a time; here it gets 40 steps
    # at once, and torch's kernels for another batch size may round the last bit differently
    # (6e-7 seen with torch 2.15 on a Xeon host): equal to float32 rounding, not bit for bit.
    np.testing.assert_allclose(arrays["actions_wolves"][:40], model.act(obs.reshape(-1, obs.shape[-1])).reshape(obs.shape[0], -1, 2), rtol=0, atol=1e-5)


def test_a_target_law_on_a_one_target_task_is_a_minari_dataset(tmp_path, monkeypatch):
    minari = pytest.importorskip("minari")
    meta = dataset.make("hunt-v1", "escape", tmp_path, episodes=4, seed=10)
    assert meta["format"] == "minari" and meta["minari_id"] == "wolfpack/hunt-v1/escape-v0"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    data = minari.load_dataset(meta["minari_id"])
    assert data.total_episodes == 4 and data.total_steps == meta["steps"]
    env = gymnasium.make(gym_id("hunt-v1"))
    for k, ep in enumerate(data.iterate_episodes()):
        obs, _ = env.reset(seed=10 + k)
        assert np.array_equal(ep.observations[0], obs)
        assert ep.observations.shape == (len(ep.actions) + 1, env.observation_space.shape[0])
        assert ep.terminations[-1] or ep.truncations[-1]
        # The recorded actions drive the Gymnasium view through the same episode.
        for t, action in enumerate(ep.actions):
            obs, reward, term, trunc, _ = env.step(action)
            assert np.array_equal(obs, ep.observations[t + 1]) and reward == pytest.approx(ep.rewards[t])
        assert (term, trunc) == (bool(ep.terminations[-1]), bool(ep.truncations[-1]))
    assert data.recover_environment().spec.id == "wolfpack/Escape-hunt-v1"


def test_bad_requests_are_refused_before_anything_is_written(tmp_path):
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(ValueError, match="not a new or empty folder"):
        dataset.make("hunt-v1", "escape", tmp_path, episodes=1)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
    with pytest.raises(ValueError, match="Minari's format holds one agent's view"):
        dataset.make("hunt-v1", "bvc", tmp_path / "x", episodes=1, fmt="minari")
    with pytest.raises(ValueError, match="say which side it plays"):
        dataset.make("hunt-v1", lambda obs: obs[:, :2], tmp_path / "y", episodes=1)
    with pytest.raises(ValueError, match="takes 50 observations, but the wolves of this task have 40"):
        dataset.make("small-pack-v1", str(WOLF_MODEL), tmp_path / "z", episodes=1)
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--task", "hunt-v9", "--policy", "bvc", "--episodes", "1", "--out", "x"], "invalid choice: 'hunt-v9'"),
        (["--task", "hunt-v1", "--policy", "nope", "--episodes", "1", "--out", "x"], "not a scripted law"),
        (["--task", "hunt-v1", "--policy", "bvc", "--episodes", "0", "--out", "x"], "--episodes"),
        (["--task", "hunt-v1", "--policy", "bvc", "--out", "x"], "the following arguments are required: --episodes"),
    ],
)
def test_the_command_refuses_bad_input_in_one_line(argv, message, tmp_path):
    run = subprocess.run([sys.executable, "-m", "wolfpack", "dataset", *argv], capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 2 and message in run.stderr and len(run.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()


def test_the_command_writes_and_reports(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "wolfpack", "dataset", "--task", "two-targets-v1", "--policy", "escape", "--episodes", "3", "--out", str(tmp_path / "d"), "--json"], capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr
    meta = json.loads(run.stdout)
    assert meta["format"] == "npz" and meta["episodes"] == 3 and meta["command"].startswith("wolfpack dataset --task two-targets-v1")
    assert dataset.load_npz(tmp_path / "d")["obs_targets"].shape[1] == 2


def test_force_replaces_a_dataset_only_once_the_new_one_is_complete(tmp_path, monkeypatch):
    out = tmp_path / "d"
    dataset.make("hunt-v1", "bvc", out, episodes=2, seed=0)
    with pytest.raises(ValueError, match=r"not a new or empty folder; choose another, or add --force"):
        dataset.make("hunt-v1", "bvc", out, episodes=3, seed=5)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(dataset, "write_npz", interrupted)
    with pytest.raises(KeyboardInterrupt):
        dataset.make("hunt-v1", "bvc", out, episodes=3, seed=5, force=True)
    assert json.loads((out / "dataset.json").read_text())["seed"] == 0  # the earlier dataset, whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]  # nothing left beside it
    monkeypatch.undo()

    meta = dataset.make("hunt-v1", "bvc", out, episodes=3, seed=5, force=True)
    assert meta["seed"] == 5 and json.loads((out / "dataset.json").read_text()) == meta
    assert dataset.load_npz(out)["episode_offsets"].shape == (4,)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]
