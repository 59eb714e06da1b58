"""The SB3 scripts of training/: train.py end to end, imitate.py → train.py --init-from,
evaluate.py against ``wolfpack hunt``, saved models reproducing their evaluation, clear errors."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import wolfpack  # noqa: E402
import yaml  # noqa: E402
from conftest import training_script  # noqa: E402
from wolfpack import cli  # noqa: E402
from wolfpack.batch import OUTCOMES, BatchEnv  # noqa: E402
from wolfpack.evaluation import HELD_OUT_SEED, rollout, wilson_interval  # noqa: E402
from wolfpack.learn.matches import evaluate_model, record_episode  # noqa: E402
from wolfpack.learn.sb3 import env_params, load_model  # noqa: E402
from wolfpack.report.evaluation import matrix_summary_markdown, scenario_name  # noqa: E402

TRAINING = Path(__file__).resolve().parents[1] / "training"
evaluate = training_script("evaluate")
imitate = training_script("imitate")
train = training_script("train")

TINY_PPO = ["--hp", "n_steps=16", "--hp", "batch_size=64", "--hp", "n_epochs=1", "--num-envs", "4", "--eval-episodes", "4", "--no-progress"]


@pytest.fixture(scope="module")
def trained_targets(tmp_path_factory):
    out = tmp_path_factory.mktemp("targets_ppo")
    assert train.main(["--side", "targets", "--algo", "ppo", "--timesteps", "256", "--seed", "3", "--out", str(out), "--eval-freq", "128", *TINY_PPO]) == 0
    return out


@pytest.fixture(scope="module")
def imitated_wolves(tmp_path_factory):
    out = tmp_path_factory.mktemp("wolves_bc")
    args = [
        "--side",
        "wolves",
        "--out",
        str(out),
        "--rounds",
        "2",
        "--steps-per-round",
        "20",
        "--num-envs",
        "2",
        "--epochs",
        "1",
        "--eval-episodes",
        "2",
        "--set",
        "env.action_mode=velocity",
        "--set",
        "env.lidar.rays=12",
    ]
    assert imitate.main(args) == 0
    return out


def test_train_writes_model_config_logs_checkpoints_and_evaluations(trained_targets):
    out = trained_targets
    for name in ("model.zip", "best_model.zip", "config.yaml", "progress.csv", "evaluations.json", "learning_curve.png", "train_summary.json", "log.txt"):
        assert (out / name).is_file(), name
    assert list(out.glob("events.out.tfevents.*")), "TensorBoard log missing"
    checkpoints = sorted((out / "checkpoints").glob("model_*_steps.zip"))
    assert checkpoints
    assert load_model(checkpoints[0]).label == f"ppo:{out.name}/{checkpoints[0].stem}"  # config found in the run folder
    config = yaml.safe_load((out / "config.yaml").read_text())
    assert config["side"] == "targets" and config["algo"] == "ppo" and config["seed"] == 3
    assert config["params"]["policies"]["wolves"] == "seed000"
    assert config["hyperparams"]["n_steps"] == 16
    summary = json.loads((out / "train_summary.json").read_text())
    assert summary["timesteps"] >= 256
    assert 0.0 < summary["env_share_of_training"] < 1.0
    history = json.loads((out / "evaluations.json").read_text())
    # one before learning, at least one during, one after
    assert len(history) >= 3 and history[0]["timesteps"] == 0
    assert all(h["episodes"] == 4 and h["first_seed"] == HELD_OUT_SEED for h in history)
    assert "eval/capture_rate" in (out / "progress.csv").read_text().splitlines()[0]


def test_saved_model_reloads_and_reproduces_its_evaluation(trained_targets):
    summary = json.loads((trained_targets / "train_summary.json").read_text())
    final = summary["final_held_out"]
    model = load_model(trained_targets)
    again = evaluate_model(model, episodes=4, seed=HELD_OUT_SEED)
    again.pop("capture_steps")
    for key in ("capture_rate", "median_capture_steps", "collision_rate", "timeout_rate", "mean_energy", "mean_return_targets", "mean_return_wolves"):
        assert again[key] == final[key], key
    # and evaluate.py reports the same row twice (the policy is deterministic)
    rows = [evaluate_json(["--episodes", "3", "--seed", "11", "--no-scripted", str(trained_targets)])["rows"][0] for _ in range(2)]
    assert rows[0] == rows[1]
    assert rows[0]["wolves"] == "seed000" and rows[0]["targets"] == f"ppo:{trained_targets.name}"


def evaluate_json(argv, capsys=None):
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert evaluate.main([*argv, "--json"]) == 0
    return json.loads(buf.getvalue())


def test_evaluate_scripted_row_equals_wolfpack_hunt_exactly(capsys):
    doc = evaluate_json(["--episodes", "40", "--seed", "7"])
    row = next(r for r in doc["rows"] if r["wolves"] == "seed000" and r["targets"] == "escape")
    cli.main(["hunt", "--episodes", "40", "--seed", "7", "--json"])
    hunt = json.loads(capsys.readouterr().out)
    for key in ("episodes", "capture_rate", "collision_rate", "timeout_rate", "median_capture_steps", "mean_energy"):
        assert row[key] == hunt[key], key
    pairs = {(r["wolves"], r["targets"]) for r in doc["rows"]}
    # every wolf law against every target law
    assert pairs == {(w, t) for w in ("seed000", "bvc", "formation") for t in ("escape", "random", "still")}
    assert doc["skipped"] == []
    bvc = next(r for r in doc["rows"] if r["wolves"] == "bvc" and r["targets"] == "escape")
    cli.main(["hunt", "--wolves", "bvc", "--episodes", "40", "--seed", "7", "--json"])
    assert bvc["capture_rate"] == json.loads(capsys.readouterr().out)["capture_rate"]
    lo, hi = row["capture_rate_ci95"]
    assert lo <= row["capture_rate"] <= hi


def test_evaluate_writes_table_json_and_plots(tmp_path):
    assert evaluate.main(["--episodes", "5", "--seed", "0", "--out", str(tmp_path / "ev")]) == 0
    for name in ("results.md", "results.json", "capture_rates.png", "capture_times.png"):
        assert (tmp_path / "ev" / name).is_file(), name
    table = (tmp_path / "ev" / "results.md").read_text()
    assert table.startswith("| wolves | targets | capture | 95% CI |") and "| seed000 | escape |" in table


def test_imitation_model_is_fine_tuned_by_train_init_from(imitated_wolves, tmp_path):
    doc = json.loads((imitated_wolves / "imitation.json").read_text())
    history = doc["rounds"]
    assert [h["beta"] for h in history] == [1.0, 0.5]
    assert doc["best_round"] == max(range(2), key=lambda r: (history[r]["held_out"]["capture_rate"], -r))
    assert history[1]["samples"] == 2 * history[0]["samples"] == 2 * 20 * 2 * 5
    bc = load_model(imitated_wolves)
    assert bc.side == "wolves" and bc.config["imitation_of"] == "seed000"
    assert math.isclose(float(bc.model.policy.log_std.detach()[0]), -1.2, rel_tol=1e-6)
    out = tmp_path / "ft"
    assert train.main(["--side", "wolves", "--timesteps", "160", "--out", str(out), "--init-from", str(imitated_wolves), *TINY_PPO]) == 0
    config = yaml.safe_load((out / "config.yaml").read_text())
    assert config["init_from"] == str(imitated_wolves.resolve())
    assert config["hyperparams"]["learning_rate"] == 1.0e-4  # the finetune section applied
    # without --params/--set the fine-tuning runs on the source's scenario, not the default one
    assert config["params"] == bc.config["params"]
    assert config["params"]["env"]["action_mode"] == "velocity" and config["params"]["env"]["lidar"]["rays"] == 12
    # the kept policy is the best round's: its held-out evaluation is reproduced from model.zip
    bc_row = evaluate_model(bc, episodes=2, seed=HELD_OUT_SEED)
    assert bc_row["mean_return_wolves"] == history[doc["best_round"]]["held_out"]["mean_return_wolves"]
    # training started from the imitation weights: its evaluation before learning is the BC policy's
    first = json.loads((out / "evaluations.json").read_text())[0]
    bc_row = evaluate_model(bc, episodes=4, seed=HELD_OUT_SEED)
    assert first["capture_rate"] == bc_row["capture_rate"] and first["mean_return_wolves"] == bc_row["mean_return_wolves"]


def test_init_from_refuses_params_that_change_the_spaces(imitated_wolves, tmp_path, capsys):
    base = ["--side", "wolves", "--timesteps", "10", "--out", str(tmp_path / "o"), "--init-from", str(imitated_wolves)]
    assert train.main([*base, "--set", "env.action_mode=unicycle"]) == 2
    assert "takes 46 observations in 'velocity' action mode, these params give 46 in 'unicycle' mode" in capsys.readouterr().err
    assert train.main([*base, "--params", str(Path(wolfpack.__file__).with_name("params.yaml"))]) == 2
    assert "these params give 50 in 'unicycle' mode" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_imitation_labels_are_the_expert_actions():
    """The data imitate.py fits: expert_actions() of the learner side, which reproduce the law."""
    b = BatchEnv(None, num_envs=2, learners="wolves", seed=5, autoreset=False, threads=1)
    hunt = rollout(env_params(None, []), episodes=2, seed=5)
    b.reset(5)
    while True:
        wolves, _ = b.expert_actions()
        out = b.step(wolves, None)
        if (out["outcome"] != 0).all():
            break
    assert [OUTCOMES[o] for o in out["outcome"]] == [r["outcome"] for r in hunt]


def test_sac_trains_and_evaluates(tmp_path):
    out = tmp_path / "sac"
    hp = ["--hp", "learning_starts=32", "--hp", "batch_size=32", "--hp", "gradient_steps=1", "--hp", "buffer_size=1000"]
    assert train.main(["--side", "targets", "--algo", "sac", "--timesteps", "128", "--out", str(out), "--num-envs", "4", "--eval-episodes", "2", "--no-progress", *hp]) == 0
    row = evaluate_json(["--episodes", "2", "--no-scripted", str(out)])["rows"][0]
    assert row["targets"] == f"sac:{out.name}"


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--side", "sheep", "--timesteps", "10", "--out", "X"], "invalid choice: 'sheep'"),
        (["--side", "wolves", "--algo", "dqn", "--timesteps", "10", "--out", "X"], "invalid choice: 'dqn'"),
        (["--side", "wolves", "--timesteps", "0", "--out", "X"], "--timesteps: must be >= 1"),
        (["--side", "wolves", "--timesteps", "10", "--out", "X", "--seed", "-1"], "seed"),
    ],
)
def test_train_rejects_bad_arguments(argv, message, capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        train.main([a.replace("X", str(tmp_path / "o")) for a in argv])
    assert e.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_missing_or_mismatched_models_give_clear_errors(tmp_path, capsys, trained_targets):
    missing = tmp_path / "nothing"
    assert train.main(["--side", "wolves", "--timesteps", "10", "--out", str(tmp_path / "o"), "--init-from", str(missing)]) == 2
    assert f"model {missing}: no such model file" in capsys.readouterr().err
    assert evaluate.main(["--episodes", "1", str(missing / "model.zip")]) == 2
    assert "no such model file" in capsys.readouterr().err
    assert train.main(["--side", "wolves", "--timesteps", "10", "--out", str(tmp_path / "o"), "--init-from", str(trained_targets)]) == 2
    assert "that model is ppo for targets, this run is ppo for wolves" in capsys.readouterr().err
    lone = tmp_path / "lone.zip"
    lone.write_bytes((trained_targets / "model.zip").read_bytes())
    assert evaluate.main(["--episodes", "1", str(lone)]) == 2
    assert "no config.yaml beside it" in capsys.readouterr().err
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "config.yaml").write_text((trained_targets / "config.yaml").read_text())
    (broken / "model.zip").write_bytes(b"not a zip")
    assert evaluate.main(["--episodes", "1", str(broken)]) == 2
    assert "cannot load it as an SB3 PPO model" in capsys.readouterr().err
    # a model whose observation layout is not this version's (here: its config says 8 rays)
    stale = tmp_path / "stale"
    stale.mkdir()
    config = yaml.safe_load((trained_targets / "config.yaml").read_text())
    config["params"]["env"]["lidar"]["rays"] = 8
    (stale / "config.yaml").write_text(yaml.safe_dump(config))
    (stale / "model.zip").write_bytes((trained_targets / "model.zip").read_bytes())
    assert evaluate.main(["--episodes", "1", str(stale)]) == 2
    assert "it takes 51 observations, but this version of wolfpack gives the targets 43" in capsys.readouterr().err
    assert train.main(["--side", "wolves", "--timesteps", "10", "--out", str(tmp_path / "o"), "--set", "world.wolfs=3"]) == 2
    assert "world.wolfs" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_wilson_interval_hand_computed():
    lo, hi = wilson_interval(94, 100)
    # p = 0.94, z = 1.96: centre (0.94 + 0.019208)/1.038416, half 1.96·sqrt(0.000564 + 0.00009604)/1.038416
    assert lo == pytest.approx(0.87529, abs=1e-4) and hi == pytest.approx(0.97223, abs=1e-4)
    assert wilson_interval(0, 20)[0] == 0.0 and wilson_interval(20, 20)[1] == 1.0
    assert wilson_interval(10, 20) == pytest.approx((0.29929, 0.70071), abs=1e-4)


def test_discounted_returns_restart_at_episode_ends():
    r = np.array([[1.0], [1.0], [1.0], [1.0]])
    ends = np.array([[False], [True], [False], [False]])
    g = imitate.discounted_returns(r, ends, 0.5)
    assert g[:, 0].tolist() == [1.5, 1.0, 1.5, 1.0]


def test_recorded_episode_equals_hunt_trajectory():
    """evaluate.py --trajectories draws what wolfpack hunt --out would record, array for array."""
    import wolfpack
    from wolfpack import logs

    params = env_params(None, [])
    mine = record_episode(params, 3)
    hunt = logs.trajectory_arrays(wolfpack.run_episodes(params, 1, 3, record=True)[0], params)
    for key in ("wolves", "targets", "energy", "interaction", "obstacle_poses", "obstacle_radius", "obstacle_kind", "border"):
        np.testing.assert_array_equal(mine[key], hunt[key], err_msg=key)
    width = mine["obstacle_vertices"].shape[1]
    np.testing.assert_allclose(mine["obstacle_vertices"], hunt["obstacle_vertices"][:, :width], atol=1e-12)
    assert (mine["outcome"], mine["capture_step"]) == (str(hunt["outcome"]), int(hunt["capture_step"]))


def test_evaluate_draws_trajectories(tmp_path, trained_targets):
    assert evaluate.main(["--episodes", "2", "--out", str(tmp_path), "--trajectories", "1", "--no-scripted", str(trained_targets)]) == 0
    assert [p.name for p in (tmp_path / "trajectories").iterdir()] == [f"seed000_vs_ppo-{trained_targets.name}_seed0.png"]


def test_target_wall_distance_is_the_final_pose_to_the_nearest_wall():
    params = env_params(None, ["world.border=[-9,-8,10,11]"])
    [row] = rollout(params, episodes=1, seed=4)
    x, y = record_episode(params, 4)["targets"][-1, 0, :2]
    assert row["target_wall_distance"] == pytest.approx(min(x + 9, 10 - x, y + 8, 11 - y), abs=1e-12)


RESULTS = Path(__file__).resolve().parents[1] / "results"


def test_published_models_reload_and_reproduce_results_md():
    """The models of RESULTS.md load in this version and, on the same 200 seeds, give its
    numbers: exactly on the machine that made them; within a few episodes elsewhere (torch's
    CPU kernels may round the last bit differently, and trajectories are chaotic)."""
    published = {(r["wolves"], r["targets"]): r for r in json.loads((RESULTS / "results.json").read_text())["rows"]}
    scripted = published[("seed000", "escape")]
    rows = {}
    for name in ("escape_ppo", "wolves_bc_vel_b", "wolves_ft"):
        m = load_model(RESULTS / "models" / name)
        row = evaluate_model(m, episodes=200, seed=0, threads=None)
        row.pop("capture_steps")
        want = published[(row["wolves"], row["targets"])]
        assert abs(row["capture_rate"] - want["capture_rate"]) <= 0.05, (name, row["capture_rate"], want["capture_rate"])
        rows[name] = row
    # the claims of RESULTS.md: (a) the learned target survives >= 2x as often as scripted escape
    assert rows["escape_ppo"]["survival_rate"] >= 2 * scripted["survival_rate"]
    # (b) imitation >= 80 % of seed000's capture rate; fine-tuned wolves capture sooner (median)
    assert rows["wolves_bc_vel_b"]["capture_rate"] >= 0.8 * scripted["capture_rate"]
    assert rows["wolves_ft"]["median_capture_steps"] < scripted["median_capture_steps"]


def test_evaluations_and_checkpoints_fall_on_rollout_boundaries(tmp_path):
    """--eval-freq 1 and --checkpoint-freq 1 with PPO rollouts of 16 steps x 4 slots: one
    evaluation and one checkpoint per rollout (the policy changes only between rollouts), never
    the same parameters twice."""
    out = tmp_path / "run"
    assert train.main(["--side", "targets", "--algo", "ppo", "--timesteps", "256", "--seed", "1", "--out", str(out), "--eval-freq", "1", "--checkpoint-freq", "1", *TINY_PPO]) == 0
    steps = [h["timesteps"] for h in json.loads((out / "evaluations.json").read_text())]
    assert steps == [0, 64, 128, 192, 256], steps  # before learning, at each later rollout, the final model
    saved = sorted(int(p.stem.split("_")[1]) for p in (out / "checkpoints").glob("model_*_steps.zip"))
    assert saved == [64, 128, 192], saved


def test_a_time_limit_sets_the_cadence_of_evaluations_and_checkpoints_unless_a_frequency_is_given():
    import argparse

    limited = argparse.Namespace(time_limit=4.0, timesteps=30_000_000)
    assert train.clock_period(limited, None, 10) == 24.0  # a tenth of 4 minutes
    assert train.clock_period(limited, None, 5) == 48.0
    assert train.clock_period(limited, 100_000, 10) is None  # --eval-freq given: it alone
    assert train.clock_period(argparse.Namespace(time_limit=None, timesteps=10), None, 10) is None
    assert not train.clock_due(0.0, None)


def test_the_matrix_names_the_scenario_it_was_played_in():
    from wolfpack.task import task_params

    assert scenario_name(task_params("hunt-v1")) == "task `hunt-v1` (the documented scenario, params.yaml)"
    # JSON's lists for tuples, and the learner's keys, do not change the scenario.
    small = json.loads(json.dumps(task_params("small-pack-v1")))
    small["env"] = dict(small["env"], last_sighting=True)
    assert scenario_name(small) == "task `small-pack-v1`"
    changed = json.loads(json.dumps(task_params("hunt-v1")))
    changed["world"]["max_steps"] = 100
    assert scenario_name(changed).startswith("params of no named task")
    doc = json.loads((TRAINING.parent / "results" / "matrix" / "matrix.json").read_text())
    assert "played in task `hunt-v1`" in matrix_summary_markdown(doc).splitlines()[0]


def test_the_sb3_scripts_ask_torch_openmp_to_wait_passively_unless_the_user_chose():
    import os
    import subprocess

    # A fresh interpreter: importing a script sets the policy before torch loads.
    code = f"import os, runpy\nrunpy.run_path({str(TRAINING / 'train.py')!r})\nimport torch\nprint(os.environ.get('OMP_WAIT_POLICY'))\n"
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    fresh = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert fresh.stdout.strip() == "PASSIVE"
    chosen = subprocess.run([sys.executable, "-c", code], env={**env, "OMP_WAIT_POLICY": "ACTIVE"}, capture_output=True, text=True, check=True)
    assert chosen.stdout.strip() == "ACTIVE"
