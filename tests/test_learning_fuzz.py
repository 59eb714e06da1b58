"""Fuzzing the learning surfaces, in the spirit of test_params_fuzz.py: generated bad recipes,
corrupted model folders and resume states (truncations and garbles of each file), and
``wolfpack train`` interrupted at random points (start-up, rollout, update, checkpoint). Each
case asserts the contract: one line and status 2 (bad input) or 130 (Ctrl-C), a ValueError
naming the file from Python, nothing lost, and the run folder absent, reusable or resumable.

About 40 s in all on a 2-core machine: a fixed number of examples, the interrupted runs in
subprocesses (a SIGINT must reach a real process)."""

from __future__ import annotations

import contextlib
import io
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import popen_interruptible
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

torch = pytest.importorskip("torch")

import wolfpack  # noqa: E402
from wolfpack import cli  # noqa: E402
from wolfpack.learn import recipe, train  # noqa: E402
from wolfpack.learn import run as learn_run  # noqa: E402
from wolfpack.models import load_tensors  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "results" / "learned" / "wolves_mappo" / "native_wolves_mappo_s2" / "wolves"  # native, 5 wolves
FUZZ = settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

# --- bad recipes ------------------------------------------------------------------------------

NOT_FINITE = st.sampled_from([math.inf, -math.inf, math.nan])
WRONG_KIND = st.sampled_from(["fast", [1, 2], {"a": 1}, True, None])
# Per key, values no recipe may hold (non-finite, out of range, of another kind).
BAD_VALUES = {
    "num_envs": st.one_of(st.integers(max_value=0), WRONG_KIND.filter(lambda v: v is not None), st.floats(allow_nan=True)),
    "n_steps": st.one_of(st.integers(max_value=0), WRONG_KIND.filter(lambda v: v is not None)),
    "epochs": st.one_of(st.integers(max_value=0), WRONG_KIND.filter(lambda v: v is not None)),
    "learning_rate": st.one_of(NOT_FINITE, st.floats(max_value=0.0), st.floats(min_value=1.0, exclude_min=True, allow_infinity=False), WRONG_KIND),
    "clip": st.one_of(NOT_FINITE, st.floats(max_value=0.0), st.floats(min_value=1.0, exclude_min=True, allow_infinity=False), WRONG_KIND),
    "max_grad_norm": st.one_of(NOT_FINITE, st.floats(max_value=0.0), WRONG_KIND),
    "gamma": st.one_of(NOT_FINITE, st.floats(min_value=1.0, exclude_min=True, allow_infinity=False), st.floats(max_value=0.0, exclude_max=True, allow_infinity=False), WRONG_KIND),
    "ent_coef": st.one_of(NOT_FINITE, st.floats(min_value=1.0, exclude_min=True, allow_infinity=False), st.floats(max_value=0.0, exclude_max=True, allow_infinity=False), WRONG_KIND),
    "vf_coef": st.one_of(NOT_FINITE, st.floats(max_value=0.0, exclude_max=True, allow_infinity=False), WRONG_KIND),
    "target_kl": st.one_of(NOT_FINITE, st.floats(max_value=0.0), WRONG_KIND.filter(lambda v: v is not None)),
    "log_std_init": st.one_of(NOT_FINITE, st.floats(min_value=2.0, exclude_min=True, allow_infinity=False), st.floats(max_value=-20.0, exclude_max=True, allow_infinity=False), WRONG_KIND),
    "hidden": st.one_of(st.just([]), st.lists(st.integers(max_value=0), min_size=1, max_size=3), st.just("64")),
    "activation": st.sampled_from(["sigmoid", "", 3]),
}


def _run_cli(argv: list[str]) -> tuple[int, str, str]:
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            cli.main(argv)
            status = 0
        except SystemExit as e:
            status = e.code
    return status, out.getvalue(), err.getvalue()


@FUZZ
@given(data=st.data())
def test_a_generated_bad_recipe_is_one_line_exit_2_and_writes_nothing(tmp_path, data):
    key = data.draw(st.sampled_from(sorted(BAD_VALUES)), label="key")
    value = data.draw(BAD_VALUES[key], label="value")
    with pytest.raises(ValueError, match=f"--hp {key}"):
        recipe("wolves", "mappo", {key: value})
    # The same value through the command line, as YAML reads it back.
    text = yaml.safe_dump(value, default_flow_style=True).strip().removesuffix("...").strip()
    out = tmp_path / f"run-{key}"
    status, stdout, stderr = _run_cli(["train", "--side", "wolves", "--timesteps", "100", "--hp", f"{key}={text}", "--out", str(out)])
    assert status == 2 and stdout == "" and stderr.count("\n") == 1 and stderr.startswith("wolfpack: error: --hp"), stderr
    assert "Traceback" not in stderr and not out.exists()


# --- corrupted model folders and resume states ---------------------------------------------


def _garble(data: bytes, how: str, where: float, seed: int) -> bytes:
    rng = np.random.default_rng(seed)
    cut = int(where * len(data))
    if how == "truncate":
        return data[:cut]
    if how == "flip":  # a few bytes changed in place
        b = bytearray(data)
        for i in rng.integers(0, max(len(b), 1), size=3):
            if b:
                b[i] ^= int(rng.integers(1, 256))
        return bytes(b)
    if how == "splice":  # random bytes in the middle
        return data[:cut] + rng.bytes(int(rng.integers(1, 64))) + data[cut:]
    return rng.bytes(len(data))  # "noise": all of it


CORRUPTION = st.tuples(st.sampled_from(["truncate", "flip", "splice", "noise"]), st.floats(0.0, 1.0), st.integers(0, 2**32 - 1))


@pytest.fixture(scope="module")
def model_bytes():
    return {name: (MODEL / name).read_bytes() for name in ("config.yaml", "policy.pt")}


@FUZZ
@given(name=st.sampled_from(["config.yaml", "policy.pt"]), corruption=CORRUPTION)
def test_a_corrupted_model_folder_loads_or_is_a_value_error_naming_the_file(tmp_path, model_bytes, name, corruption):
    folder = tmp_path / "model"
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir()
    for file, data in model_bytes.items():
        (folder / file).write_bytes(_garble(data, *corruption) if file == name else data)
    try:
        policy = wolfpack.load_policy(folder)
    except ValueError as e:
        message = str(e)
        assert str(folder) in message and "\n" not in message and "weights_only" not in message, message
        assert name in message or "config.yaml" in message, message  # the file at fault (a damaged config names itself)
        return
    # It loaded: then it acts as a model must, finite actions in the box.
    actions = policy.act(np.zeros((policy.actor.agents if hasattr(policy, "actor") else 5, policy.obs_dim), np.float32))
    assert np.isfinite(actions).all() and (np.abs(actions) <= 1).all()


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("fuzz") / "run"
    _tiny(out, timesteps=600)
    return out


TINY_HP = {"num_envs": 4, "n_steps": 16, "epochs": 1, "minibatch_size": 32, "hidden": [8]}


def _tiny(out: Path, timesteps: int, resume: bool = False) -> dict:
    return train(
        "targets",
        "mappo",
        out=out,
        timesteps=timesteps,
        device="cpu",
        progress=False,
        overrides={"world.max_steps": 40},
        hp=TINY_HP,
        threads=1,
        torch_threads=1,
        eval_episodes=2,
        evaluations=1,
        resume=resume,
    )


@settings(max_examples=15, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(corruption=CORRUPTION)
def test_a_corrupted_resume_state_resumes_or_is_a_value_error_naming_it(tmp_path, tiny_run, corruption):
    path = tmp_path / "trainer.pt"
    path.write_bytes(_garble((tiny_run / "trainer.pt").read_bytes(), *corruption))
    try:
        load_tensors(path)
    except ValueError as e:
        assert str(path) in str(e) and "weights_only" not in str(e)


# --- interrupted training -----------------------------------------------------------------------

#: A run of many short updates (64 agent-steps each, a checkpoint every 4,000), so that a
#: random instant lands in a rollout, an update, an evaluation or a checkpoint.
TRAIN_ARGS = ["train", "--side", "targets", "--set", "world.max_steps=40", "--threads", "1", "--torch-threads", "1", "--eval-episodes", "2", "--evaluations", "50", "--no-progress"]
TRAIN_ARGS += [a for key, value in TINY_HP.items() for a in ("--hp", f"{key}={yaml.safe_dump(value, default_flow_style=True).strip()}")]
#: Seconds after config.yaml appears at which Ctrl-C lands: 0 is start-up (the trainer opening
#: its logs), the others drawn (seeded) over the first three seconds of training.
DELAYS = [0.0, *np.round(np.random.default_rng(0).uniform(0.05, 3.0, size=2), 2).tolist()]


@pytest.mark.skipif(sys.platform == "win32", reason="SIGINT")
@pytest.mark.parametrize("delay", DELAYS)
def test_training_interrupted_anywhere_leaves_a_folder_a_rerun_reuses_or_resume_continues(tmp_path, delay):
    out = tmp_path / "run"
    # PYTHONFAULTHANDLER: a child that hangs is sent SIGABRT below and prints every thread's stack.
    env = {**os.environ, "PYTHONFAULTHANDLER": "1"}
    proc = popen_interruptible([sys.executable, "-m", "wolfpack", *TRAIN_ARGS, "--timesteps", "20000", "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT, env=env)
    try:
        deadline = time.monotonic() + 60
        while not (out / "config.yaml").is_file():
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "the run never started"
            time.sleep(0.005)
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        try:
            stdout, stderr = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGABRT)
            stdout, stderr = proc.communicate(timeout=30)
            pytest.fail(f"Ctrl-C {delay} s after config.yaml: still running 60 s later; its threads' stacks:\n{stderr[-8000:]}")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    print(f"Ctrl-C {delay} s after config.yaml: exit {proc.returncode}: {stderr.strip()}")  # pytest -rP shows it
    assert proc.returncode == 130 and stdout == "", stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"wolfpack: interrupted; {out} holds "), stderr
    if learn_run.without_progress(out):
        assert "no progress yet" in lines[0]
        rows_before = 0
    else:  # saved where it stopped (0 agent-steps when no update had finished)
        assert "continue with --resume" in lines[0] and load_tensors(out / "trainer.pt")["agent_steps"] >= 0
        rows_before = (out / "progress.csv").read_text().count("\n") - 1
    # Either way the same run goes on there, from its state or afresh, and keeps its rows.
    status, stdout, stderr = _run_cli([*TRAIN_ARGS, "--timesteps", "1", "--out", str(out), "--resume"])
    assert status == 0, stderr
    assert (out / "progress.csv").read_text().count("\n") - 1 >= max(rows_before, 1)
