"""A run folder of ``wolfpack train`` is never stuck: recipes that would make training die
(non-finite or absurd values, rollout buffers beyond the machine's memory) are refused before
anything is written, and a run stopped during start-up leaves a folder that a rerun reuses and
``--resume`` continues."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest

torch = pytest.importorskip("torch")

from wolfpack.learn import recipes, train, trainer  # noqa: E402
from wolfpack.learn import run as learn_run  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TINY = {"num_envs": 4, "n_steps": 16, "epochs": 1, "minibatch_size": 32, "hidden": [8]}


def tiny(out: Path, **kw):
    kw.setdefault("hp", TINY)
    return train(
        "targets",
        "mappo",
        out=out,
        timesteps=kw.pop("timesteps", 600),
        device="cpu",
        progress=False,
        overrides={"world.max_steps": 40},
        threads=1,
        torch_threads=1,
        eval_episodes=2,
        evaluations=1,
        **kw,
    )


@pytest.mark.parametrize(
    "hp, message",
    [
        ("learning_rate=.inf", "--hp learning_rate: must be a number in (0, 1], got inf"),
        ("learning_rate=2", "--hp learning_rate: must be a number in (0, 1], got 2"),
        ("log_std_init=.nan", "--hp log_std_init: must be a number in [-20, 2], got nan"),
        ("log_std_init=1000", "--hp log_std_init: must be a number in [-20, 2], got 1000"),
        ("ent_coef=.inf", "--hp ent_coef: must be a number in [0, 1], got inf"),
        ("vf_coef=.nan", "--hp vf_coef: must be a finite number >= 0"),
        ("max_grad_norm=.inf", "--hp max_grad_norm: must be a finite number > 0"),
        ("clip=.nan", "--hp clip: must be a number in (0, 1]"),
        ("target_kl=.inf", "--hp target_kl: must be null or a finite number > 0"),
        ("n_steps=1000000000", "--hp num_envs x n_steps: the rollout buffers of 256 worlds x 1,000,000,000 steps take"),
    ],
)
def test_a_recipe_that_cannot_train_is_refused_before_anything_is_written(tmp_path, hp, message):
    out = tmp_path / "run"
    run = subprocess.run([sys.executable, "-m", "wolfpack", "train", "--side", "wolves", "--timesteps", "1000", "--hp", hp, "--out", str(out)], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and message in run.stderr, run.stderr
    assert not out.exists()


def test_the_memory_check_counts_every_buffer_and_names_the_keys():
    r = recipes.recipe("wolves", "mappo")
    one = recipes.rollout_bytes(r, agents=5, obs_dim=54, state_dim=98, centralised=True)
    assert one == 4 * 256 * 64 * (5 * (54 + 7) + 1 + 98)
    assert recipes.rollout_bytes(r, agents=5, obs_dim=54, state_dim=98, centralised=False) < one
    recipes.check_memory(r, one, available=one)
    with pytest.raises(ValueError, match=r"--hp num_envs x n_steps: .* 256 worlds x 64 steps .* lower num_envs or n_steps"):
        recipes.check_memory(r, one, available=one - 1)


def _stop_during_start_up(monkeypatch):
    """Ctrl-C where the trainer opens its logs: after config.yaml and progress.csv exist,
    before the first update (the window in which a run used to be left stuck)."""

    def interrupted(out):
        raise KeyboardInterrupt

    monkeypatch.setattr(trainer, "tensorboard", interrupted)


@pytest.mark.parametrize("resume", [False, True], ids=["rerun", "resume"])
def test_a_run_stopped_during_start_up_is_reused_by_a_rerun_or_resume(tmp_path, monkeypatch, resume):
    out = tmp_path / "run"
    with monkeypatch.context() as patched:
        _stop_during_start_up(patched)
        with pytest.raises(KeyboardInterrupt, match="holds no progress yet: the same command starts afresh there"):
            tiny(out)
    assert sorted(p.name for p in out.iterdir()) == ["config.yaml", "progress.csv"]
    summary = tiny(out, resume=resume)
    assert summary["agent_steps"] >= 600 and (out / "trainer.pt").is_file()
    with open(out / "progress.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows and rows[0]["update"] == "1"  # the header written again, the first update its first row


def test_a_folder_with_progress_or_foreign_files_is_never_reused(tmp_path):
    out = tmp_path / "run"
    tiny(out)
    assert not learn_run.without_progress(out)  # models and rows: --resume or another folder
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "config.yaml").write_text("trainer: something else\n")
    assert not learn_run.without_progress(mine)
    (mine / "config.yaml").write_text("trainer: wolfpack train\n")
    (mine / "notes.txt").write_text("mine")
    assert not learn_run.without_progress(mine)
    with pytest.raises(ValueError, match="not a new or empty folder"):
        tiny(mine)
    assert (mine / "notes.txt").read_text() == "mine"


def test_a_ctrl_c_in_the_middle_of_writing_the_configuration_leaves_none(tmp_path, monkeypatch):
    """config.yaml is written whole or not at all: a Ctrl-C landing half way through the write
    leaves no configuration that a rerun or --resume could not read."""
    out = tmp_path / "run"
    real = Path.write_text

    def half_then_ctrl_c(self, data, *args, **kwargs):
        if "config.yaml" in self.name:
            real(self, data[: len(data) // 2], *args, **kwargs)
            raise KeyboardInterrupt
        return real(self, data, *args, **kwargs)

    with monkeypatch.context() as patched:
        patched.setattr(Path, "write_text", half_then_ctrl_c)
        with pytest.raises(KeyboardInterrupt, match="holds no progress yet"):
            tiny(out)
    assert not (out / "config.yaml").exists() and not list(out.glob(".config.yaml*"))
    assert tiny(out)["agent_steps"] >= 600  # the same command starts afresh there
    assert tiny(out, resume=True, timesteps=1200)["agent_steps"] >= 1200  # and goes on from it
