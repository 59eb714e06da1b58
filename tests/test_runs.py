"""wolfpack.learn.runs: training runs in child processes, trained once and continued where they
stopped, and a finished run's held-out evaluation cached in its folder."""

from __future__ import annotations

import json
import subprocess
import sys
from types import SimpleNamespace

import pytest
from wolfpack.learn import runs


def test_a_finished_run_is_read_back_and_never_trained_again(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "summary.json").write_text(json.dumps({"agent_steps": 7}))
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: pytest.fail("trained again"))
    assert runs.train(folder, ["--side", "wolves"], tmp_path / "run.log") == {"agent_steps": 7}


def test_a_run_stopped_before_its_first_state_starts_again_in_a_cleared_folder(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "left_over").write_text("half")
    calls = []

    def fake_run(cmd, **kw):
        calls.append(cmd)
        assert not (folder / "left_over").exists()  # cleared before the trainer starts
        folder.mkdir(exist_ok=True)
        (folder / "summary.json").write_text(json.dumps({"agent_steps": 3}))
        return SimpleNamespace(returncode=0)

    monkeypatch.setattr(subprocess, "run", fake_run)
    assert runs.train(folder, ["--side", "targets", "--seed", "2"], tmp_path / "run.log") == {"agent_steps": 3}
    assert calls[0] == [sys.executable, "-m", "wolfpack", "train", "--side", "targets", "--seed", "2", "--no-progress", "--out", str(folder)]


def test_a_run_with_a_saved_state_is_resumed_and_a_failure_names_its_log(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "trainer.pt").write_bytes(b"state")
    calls = []

    def failing(cmd, stdout, **kw):
        calls.append(cmd)
        stdout.write("wolfpack: error: something broke\n")
        return SimpleNamespace(returncode=3)

    monkeypatch.setattr(subprocess, "run", failing)
    with pytest.raises(RuntimeError, match=r"failed \(exit 3\): wolfpack: error: something broke \(log: .*run.log\)"):
        runs.train(folder, ["--side", "wolves"], tmp_path / "run.log")
    assert calls[0][-1] == "--resume" and (folder / "trainer.pt").is_file()  # continued, not cleared


def test_evaluations_are_cached_per_episode_count_and_redone_when_asked(tmp_path):
    made = []

    def evaluate():
        made.append(1)
        return {"score": 0.5 + len(made)}

    assert runs.held_out(tmp_path, 200, evaluate) == {"episodes": 200, "score": 1.5}
    assert runs.held_out(tmp_path, 200, evaluate) == {"episodes": 200, "score": 1.5}  # from the cache
    assert runs.held_out(tmp_path, 100, evaluate) == {"episodes": 100, "score": 2.5}  # another count
    assert runs.held_out(tmp_path, 100, evaluate, reevaluate=True) == {"episodes": 100, "score": 3.5}
    assert len(made) == 3
