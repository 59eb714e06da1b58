"""Messages in the project's words: each bad input names the option, the key or the argument
the user gave, with the allowed range, never a derived value or a Python type the user never
typed."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import wolfpack

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "results" / "learned" / "wolves_mappo" / "native_wolves_mappo_s2" / "wolves"  # native, 5 wolves


def one_line_exit_2(tmp_path, *args) -> str:
    run = subprocess.run([sys.executable, "-m", "wolfpack", *map(str, args)], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and run.stdout == "", run.stderr
    assert list(tmp_path.iterdir()) == []  # nothing written
    return run.stderr


@pytest.mark.parametrize("seed", [str(2**64), str(2**63), str(10**13)])
def test_a_train_seed_out_of_range_names_the_range_the_user_can_give(tmp_path, seed):
    pytest.importorskip("torch")
    line = one_line_exit_2(tmp_path, "train", "--side", "wolves", "--timesteps", "100", "--seed", seed, "--out", "run")
    assert f"--seed must be an integer in [0, 10^13), got {seed}" in line and "Overflow" not in line


def test_the_train_help_states_the_seed_limit(tmp_path):
    run = subprocess.run([sys.executable, "-m", "wolfpack", "train", "--help"], capture_output=True, text=True, timeout=60)
    assert "0 <= S < 10^13" in " ".join(run.stdout.split())


def test_an_hp_without_a_value_names_hp(tmp_path):
    pytest.importorskip("torch")
    line = one_line_exit_2(tmp_path, "train", "--side", "wolves", "--timesteps", "100", "--hp", "learning_rate", "--out", "run")
    assert line.startswith("wolfpack: error: --hp 'learning_rate': expected key=value") and "--set" not in line


@pytest.mark.parametrize(
    "args",
    [
        ("benchmark", "--wolves", "wolfy"),
        ("dataset", "--task", "hunt-v1", "--policy", "wolfy", "--episodes", "1", "--out", "d"),
    ],
    ids=["benchmark", "dataset"],
)
def test_the_policy_scored_or_recorded_is_called_a_policy(tmp_path, args):
    line = one_line_exit_2(tmp_path, *args)
    assert "policy 'wolfy': not a scripted law" in line and "opponent" not in line


def test_act_refuses_a_generator_or_flag_of_another_kind_naming_it():
    pytest.importorskip("torch")
    policy = wolfpack.load_policy(MODEL)
    obs = np.zeros((5, policy.obs_dim), np.float32)
    with pytest.raises(TypeError, match="rng must be a numpy random generator"):
        policy.act(obs, deterministic=False, rng=3)
    with pytest.raises(TypeError, match="rng must be a numpy random generator"):
        policy.act(obs, rng=3)
    for flag in ("no", None, 0):
        with pytest.raises(TypeError, match="deterministic must be True or False"):
            policy.act(obs, deterministic=flag)
    assert policy.act(obs, deterministic=np.bool_(False), rng=np.random.default_rng(0)).shape == (5, 2)
    # A loaded model driving a side is named by its own name, not its class.
    assert wolfpack.Opponent(policy).name == policy.name != "NativePolicy"


def test_a_non_finite_observation_is_named_not_answered_with_nan():
    pytest.importorskip("torch")
    policy = wolfpack.load_policy(MODEL)
    obs = np.zeros((5, policy.obs_dim), np.float32)
    obs[3, 7] = np.nan
    for deterministic in (True, False):
        with pytest.raises(ValueError, match="observation row 3 holds NaN or inf"):
            policy.act(obs, deterministic=deterministic)
