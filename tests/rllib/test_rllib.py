"""RLlib (new API stack) on wolfpack, through RLlib's own entry points: PPOConfig, RLlib's
``ParallelPettingZooEnv``, env runners as Ray actors, a cluster started with ``ray start``.

Runs in its own virtualenv (ray pins gymnasium): ``bash tests/rllib/run.sh`` makes it and runs
this file (README's test command does). Ray is kept on loopback here
(``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, set by run.sh and below), so no test traffic leaves
127.0.0.1; on a real cluster leave that variable unset.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")

ray = pytest.importorskip("ray")  # run.sh installs it; the main test run never collects this file

import wolfpack  # noqa: E402
from conftest import training_script  # noqa: E402

REPO = Path(__file__).resolve().parents[2]

rllib_train = training_script("rllib_train")

SMALL = ["--train-batch", "400", "--minibatch", "200", "--epochs", "1"]


@pytest.fixture
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_ppo_new_api_stack_two_env_runners_two_policies(local_ray):
    """One PPO iteration, 2 env runners, one RLModule per side, on RLlib's own PettingZoo
    wrapper of ``wolfpack.parallel_env(learners="both")``."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv
    from ray.tune.registry import register_env

    register_env("wolfpack_test", lambda cfg: ParallelPettingZooEnv(wolfpack.parallel_env(learners="both")))
    config = (
        PPOConfig()
        .environment("wolfpack_test")
        .env_runners(num_env_runners=2)
        .multi_agent(policies={"wolves", "targets"}, policy_mapping_fn=lambda aid, *a, **k: "wolves" if aid.startswith("wolf") else "targets")
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={"wolves": RLModuleSpec(), "targets": RLModuleSpec()}))
        .training(train_batch_size_per_learner=400, minibatch_size=200, num_epochs=1)
    )
    algo = config.build_algo()
    try:
        result = algo.train()
    finally:
        algo.stop()
    assert result["env_runners"]["num_env_steps_sampled_lifetime"] >= 400
    assert set(result["learners"]) >= {"wolves", "targets"}
    assert result["fault_tolerance"]["num_healthy_workers"] == 2
    steps = result["env_runners"]["num_agent_steps_sampled_lifetime"]
    assert set(steps) == {"wolf_0", "wolf_1", "wolf_2", "wolf_3", "wolf_4", "target_0"}


def test_rllib_train_two_iterations_checkpoint_and_resume(tmp_path):
    out = tmp_path / "run"
    assert rllib_train.main(["--iterations", "2", "--num-env-runners", "2", "--num-cpus", "2", "--out", str(out), *SMALL]) == 0
    rows = list(csv.DictReader(open(out / "progress.csv")))
    assert [int(r["iteration"]) for r in rows] == [1, 2]
    assert {"return_wolves", "return_targets"} <= set(rows[0])
    assert int(rows[1]["env_steps"]) >= 800
    assert (out / "checkpoint").is_dir() and json.loads((out / "summary.json").read_text())["iterations_this_run"] == 2
    # A used folder is refused; --resume goes on from the checkpoint.
    assert rllib_train.main(["--iterations", "1", "--out", str(out)]) == 2
    assert rllib_train.main(["--iterations", "1", "--num-env-runners", "1", "--num-cpus", "2", "--resume", str(out), *SMALL]) == 0
    rows = list(csv.DictReader(open(out / "progress.csv")))
    assert [int(r["iteration"]) for r in rows] == [1, 2, 3]
    assert int(rows[2]["env_steps"]) > int(rows[1]["env_steps"])


def test_progress_has_a_return_column_per_module_even_before_an_episode_ends():
    """An iteration that finishes no episode (short iterations on a loaded machine) must not fix
    progress.csv's header without the return columns."""
    sides = rllib_train.build_parser().parse_args([])
    assert rllib_train.module_ids(sides) == ["wolves", "targets"]
    assert rllib_train.returns_of({"env_runners": {}}, ["wolves", "targets"]) == {"return_wolves": "", "return_targets": ""}
    result = {"env_runners": {"module_episode_returns_mean": {"targets": 1.23456}}}
    assert rllib_train.returns_of(result, ["wolves", "targets"]) == {"return_wolves": "", "return_targets": 1.2346}
    shared = rllib_train.build_parser().parse_args(["--policies", "shared"])
    assert rllib_train.module_ids(shared) == ["shared"]


def test_rllib_train_one_shared_policy_in_process(tmp_path):
    out = tmp_path / "shared"
    assert rllib_train.main(["--policies", "shared", "--iterations", "1", "--num-env-runners", "0", "--num-cpus", "1", "--out", str(out), *SMALL]) == 0
    rows = list(csv.DictReader(open(out / "progress.csv")))
    assert "return_shared" in rows[0]


def test_rllib_train_joins_a_cluster_started_with_ray_start(tmp_path):
    """What a user does on many machines, on one: ``ray start --head``, then the script with
    ``--address auto`` (its env runners are the cluster's actors)."""
    ray_bin = shutil.which("ray", path=str(Path(sys.executable).parent)) or shutil.which("ray")
    assert ray_bin, "the ray command line is missing"
    env = {**os.environ, "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}
    # A short folder of its own: Ray's Unix sockets live under it (paths are limited to 107 bytes).
    temp = tempfile.mkdtemp(prefix="ray", dir="/tmp")
    started = subprocess.run(
        [ray_bin, "start", "--head", "--num-cpus", "2", "--include-dashboard", "false", "--disable-usage-stats", f"--temp-dir={temp}"], env=env, capture_output=True, text=True, timeout=120
    )
    assert started.returncode == 0, started.stderr[-2000:]
    try:
        out = tmp_path / "cluster"
        proc = subprocess.run(
            [sys.executable, str(REPO / "training" / "rllib_train.py"), "--address", "auto", "--iterations", "1", "--num-env-runners", "1", "--out", str(out), *SMALL],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
        assert json.loads((out / "summary.json").read_text())["ray_address"] == "auto"
    finally:
        subprocess.run([ray_bin, "stop", "--force"], env=env, capture_output=True, timeout=120)
        shutil.rmtree(temp, ignore_errors=True)


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["--policies", "shared", "--learners", "wolves"], "--learners both"),
        (["--minibatch", "9000"], "--minibatch"),
        (["--num-env-runners", "-1"], "--num-env-runners"),
        (["--resume", "/nonexistent/run"], "--resume"),
        (["--set", "world.wolvs=3"], "world.wolvs"),
        (["--address", "127.0.0.1:1"], "no Ray head answers"),  # fails at once instead of Ray's minutes of retries
    ],
)
def test_rllib_train_bad_arguments_exit_2_with_one_line(tmp_path, capsys, argv, fragment):
    assert rllib_train.main([*argv, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and fragment in err[0] and err[0].startswith("rllib_train.py: error:")
    assert not (tmp_path / "o").exists()
