"""The benchmark's task suite (docs/tasks.md): frozen params files, ``task=`` on every
interface, the Gymnasium ids, and each task's scripted outcomes pinned."""

from __future__ import annotations

import hashlib
import json
import pickle
import subprocess
import sys
from collections import Counter

import gymnasium
import numpy as np
import pytest
import wolfpack
import yaml
from wolfpack import _core
from wolfpack.task import TASK_ORDER, TASKS_DIR, gym_id, outcome_changes, single_target_tasks, task_changes, task_params

#: seed000 vs escape (each task's own laws), episodes 0-199: (captured, collision, timeout,
#: total steps). A task's version must change whenever anything changes these: a failure here
#: means either a bug or a new task version (docs/tasks.md, "Versions").
PINNED = {
    "hunt-v1": (196, 0, 4, 33840),
    "open-v1": (200, 0, 0, 30492),
    "cluttered-v1": (189, 1, 10, 37488),
    "fast-target-v1": (181, 0, 19, 41298),
    "small-pack-v1": (196, 0, 4, 33091),
    "two-targets-v1": (31, 0, 169, 57932),
    "short-sight-v1": (193, 0, 7, 36603),
}

#: (trajectory digest, observation digest) of each task: see trajectory_digest and
#: observation_digest. Any change to a bit of the world or of what the learners observe moves
#: them; the outcome pins above say whether the change also moved outcomes. (The trajectories
#: gained the laws' modes, wolf_mode and target_mode: without those two arrays the digests are
#: the earlier pins, so recording the modes moved no other bit.)
DIGESTS = {
    "hunt-v1": ("278cc6f457eb05c3", "d931819290409c73"),
    "open-v1": ("820f6844ddc57f3e", "66eb12a5ed936840"),
    "cluttered-v1": ("ebd23f4dd3ac472e", "69536345b038133e"),
    "fast-target-v1": ("73efb64a151740d2", "fb55bb6c6657badd"),
    "small-pack-v1": ("4a5d41f2bfdc30ca", "ec3f54d72e9e6a58"),
    "two-targets-v1": ("9468d21a7caf1587", "4f8de55cd71b0197"),
    "short-sight-v1": ("901b775aa4d72b44", "4b68cb7db3b75054"),
}

#: A digest of each task file's params as written: a released task's file is never edited (a
#: change to what a learner observes or is paid changes learned outcomes too, even where the
#: scripted ones above stay).
FROZEN = {
    "hunt-v1": "cc7d17ef7e73d56e",
    "open-v1": "9515990832bd2cc9",
    "cluttered-v1": "d41876bb1d490b68",
    "fast-target-v1": "cf9c00bdc0a21b4b",
    "small-pack-v1": "bea6978d65b09ff4",
    "two-targets-v1": "f3818416ffdee225",
    "short-sight-v1": "c64b062063bccd9a",
}


@pytest.mark.parametrize("name", TASK_ORDER)
def test_each_task_file_is_as_released(name):
    written = yaml.safe_load((TASKS_DIR / f"{name}.yaml").read_text())
    assert written["name"] == name
    assert hashlib.sha256(json.dumps(written["params"], sort_keys=True).encode()).hexdigest()[:16] == FROZEN[name]


def trajectory_digest(name: str, episodes: int = 20, threads: int | None = None) -> str:
    """Every recorded array of the scripted episodes 0..episodes-1 of a task, bit for bit."""
    h = hashlib.sha256()
    for result in wolfpack.run_episodes(task_params(name), episodes, 0, record=True, threads=threads):
        for key in sorted(result["trajectory"]):
            h.update(key.encode())
            value = result["trajectory"][key]
            # obstacle_shapes is a list of dicts: its JSON (Python writes floats round-trip exact);
            # the arrays' own bytes.
            h.update(json.dumps(value, sort_keys=True).encode() if isinstance(value, list) else np.ascontiguousarray(value).tobytes())
    return h.hexdigest()[:16]


def observation_digest(name: str, steps: int = 120, threads: int | None = None) -> str:
    """Both sides' observations, bit for bit, over ``steps`` steps of 4 worlds where every agent
    learns and turns gently (the lidar noise of short-sight-v1 included)."""
    batch = wolfpack.BatchEnv(task=name, num_envs=4, learners="both", seed=0, threads=threads)
    out = batch.reset(0)
    h = hashlib.sha256()
    wolves = np.tile(np.array([0.6, 0.3], np.float32), (4, batch.n_wolves, 1))
    targets = np.tile(np.array([0.8, -0.2], np.float32), (4, batch.n_targets, 1))
    for _ in range(steps):
        h.update(np.ascontiguousarray(out["obs_wolves"]).tobytes())
        h.update(np.ascontiguousarray(out["obs_targets"]).tobytes())
        out = batch.step(wolves, targets)
    return h.hexdigest()[:16]


@pytest.mark.parametrize("name", TASK_ORDER)
def test_each_task_reproduces_its_pinned_digests(name):
    # The core takes every transcendental function from the pure-Rust libm crate and draws its
    # normal variates with its own ziggurat on them (docs/architecture.md, "How the core is
    # compiled"), so these bits are the same on every platform that passes this test: a
    # baseline measured anywhere is reproduced exactly everywhere.
    assert (trajectory_digest(name), observation_digest(name)) == DIGESTS[name]


def test_the_digests_do_not_depend_on_the_thread_count():
    assert (trajectory_digest("short-sight-v1", threads=1), observation_digest("short-sight-v1", threads=1)) == DIGESTS["short-sight-v1"]


@pytest.mark.parametrize("name", TASK_ORDER)
def test_each_task_plays_its_pinned_scripted_outcomes(name):
    results = wolfpack.run_episodes(task_params(name), 200, 0)
    counts = Counter(r["outcome"] for r in results)
    assert (counts["captured"], counts["collision"], counts["timeout"], sum(r["steps"] for r in results)) == PINNED[name]


def test_the_suite_lists_every_task_with_a_description_and_the_documented_scenario_first():
    listed = wolfpack.tasks()
    assert list(listed) == list(PINNED) == list(TASK_ORDER)
    assert all(isinstance(d, str) and 20 < len(d) < 200 for d in listed.values())
    assert len(TASK_ORDER) >= 7


def test_hunt_v1_is_the_documented_scenario():
    # When the documented scenario's defaults change, hunt-v1 stays as it was: this fails, and
    # the new defaults become a new version (hunt-v2) beside it.
    assert task_params("hunt-v1") == _core.validate_params(None)
    assert task_changes("hunt-v1") == {}


def test_each_task_changes_what_its_description_says():
    changes = {name: task_changes(name) for name in TASK_ORDER}
    assert all(v == 0 for k, v in changes["open-v1"].items() if k.endswith(("circles", "polygons")))
    clutter = task_params("cluttered-v1")["obstacles"]
    assert sum(clutter[k] for k in ("static_circles", "moving_circles", "static_polygons", "moving_polygons")) >= 30
    assert changes["fast-target-v1"] == {"agents.target.v_max": 2.0}
    assert changes["small-pack-v1"] == {"world.wolves": 3}
    assert changes["two-targets-v1"] == {"world.targets": 2}
    sight = task_params("short-sight-v1")
    assert sight["agents"]["wolf"]["sense_radius"] == sight["agents"]["target"]["sense_radius"] == 1.5
    assert sight["env"]["lidar"]["noise"] > 0
    # Every task differs from the others somewhere.
    assert len({json.dumps(task_params(n), sort_keys=True) for n in TASK_ORDER}) == len(TASK_ORDER)


def test_task_params_are_copies_and_take_overrides():
    first = task_params("open-v1")
    first["world"]["wolves"] = 9
    assert task_params("open-v1")["world"]["wolves"] == 5
    assert task_params("open-v1", {"world.wolves": 4})["world"]["wolves"] == 4


def test_outcome_changes_names_the_overrides_outside_who_plays_and_what_a_learner_observes_and_is_paid():
    assert outcome_changes({"env.lidar.rays": 8, "rewards.wolves.shaping": 0.0, "policies.wolves": "bvc"}) == []
    assert outcome_changes({"world.wolves": 4, "env.last_sighting": True}) == ["world.wolves"]


def test_every_interface_plays_the_task():
    batch = wolfpack.BatchEnv(task="small-pack-v1", num_envs=2)
    assert batch.task == "small-pack-v1" and batch.n_wolves == 3
    assert pickle.loads(pickle.dumps(batch)).params == batch.params
    assert wolfpack.parallel_env(task="small-pack-v1").possible_agents == ["wolf_0", "wolf_1", "wolf_2"]
    assert wolfpack.env(task="two-targets-v1", learners="targets").possible_agents == ["target_0", "target_1"]
    venv = wolfpack.make_vec_env(task="fast-target-v1", num_envs=2, learners="targets")
    assert venv.batch.params["agents"]["target"]["v_max"] == 2.0
    # Overrides apply on top of the task.
    assert wolfpack.BatchEnv(task="open-v1", world__wolves=4).n_wolves == 4


def test_the_gymnasium_ids_are_the_single_target_tasks():
    assert "two-targets-v1" not in single_target_tasks()
    for name in single_target_tasks():
        assert gym_id(name) in gymnasium.registry
    env = gymnasium.make("wolfpack/Escape-short-sight-v1")
    env.reset(seed=1)
    assert env.unwrapped.params == _core.validate_params(task_params("short-sight-v1"), resolve=True)
    assert "wolfpack/Escape-two-targets-v1" not in gymnasium.registry


def test_a_bad_task_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown task 'hunt-v9': one of hunt-v1, open-v1"):
        wolfpack.BatchEnv(task="hunt-v9")
    with pytest.raises(ValueError, match="unknown task"):
        wolfpack.parallel_env(task="")
    with pytest.raises(TypeError, match="task must be a task's name"):
        wolfpack.BatchEnv(task=1)
    with pytest.raises(ValueError, match="give params or task, not both"):
        wolfpack.BatchEnv({"world": {"wolves": 3}}, task="open-v1")


def test_hunt_takes_a_task_and_says_so():
    run = subprocess.run([sys.executable, "-m", "wolfpack", "hunt", "--task", "fast-target-v1", "--episodes", "3"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith("task fast-target-v1: 3 episodes")
    law = subprocess.run([sys.executable, "-m", "wolfpack", "hunt", "--task", "open-v1", "--wolves", "bvc", "--episodes", "1"], capture_output=True, text=True)
    assert law.stdout.startswith("task open-v1: 1 episodes, seeds 0..0: 5 bvc wolves")
    modified = subprocess.run([sys.executable, "-m", "wolfpack", "hunt", "--task", "open-v1", "--set", "world.wolves=4", "--episodes", "2"], capture_output=True, text=True)
    assert modified.stdout.startswith("task open-v1 (modified): 2 episodes, seeds 0..1: 4 seed000")


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--task", "nope"], "invalid choice: 'nope'"),
        (["--task", "open-v1", "--params", "params.yaml"], "not allowed with argument"),
    ],
)
def test_hunt_refuses_a_bad_task_in_one_line(argv, message):
    run = subprocess.run([sys.executable, "-m", "wolfpack", "hunt", *argv], capture_output=True, text=True)
    assert run.returncode == 2
    assert message in run.stderr and len(run.stderr.strip().splitlines()) == 1
