"""training/sweep.py: what the baseline sweeps share — runs trained once, evaluations cached."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "training"))

import sweep  # noqa: E402


def test_a_finished_run_is_read_back_and_never_trained_again(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "summary.json").write_text(json.dumps({"agent_steps": 7}))
    monkeypatch.setattr(subprocess, "run", lambda *a, **k: (_ for _ in ()).throw(AssertionError("trained again")))
    assert sweep.train_once(folder, ["--side", "wolves"]) == {"agent_steps": 7}


def test_an_interrupted_run_starts_again_in_a_cleared_folder(tmp_path, monkeypatch):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "checkpoint_left_over").write_text("half")
    calls = []

    def fake_run(cmd, check, stdout):
        calls.append(cmd)
        assert not folder.exists()  # cleared before the trainer starts
        folder.mkdir()
        (folder / "summary.json").write_text(json.dumps({"agent_steps": 3}))

    monkeypatch.setattr(subprocess, "run", fake_run)
    assert sweep.train_once(folder, ["--side", "targets", "--seed", "2"]) == {"agent_steps": 3}
    assert calls[0][1:] == ["-m", "wolfpack.cli", "train", "--side", "targets", "--seed", "2", "--no-progress", "--out", str(folder)]


def test_evaluations_are_cached_per_episode_count_and_redone_when_asked(tmp_path):
    made = []

    def evaluate():
        made.append(1)
        return {"score": 0.5 + len(made)}

    assert sweep.held_out(tmp_path, 200, evaluate) == {"episodes": 200, "score": 1.5}
    assert sweep.held_out(tmp_path, 200, evaluate) == {"episodes": 200, "score": 1.5}  # from the cache
    assert sweep.held_out(tmp_path, 100, evaluate) == {"episodes": 100, "score": 2.5}  # another count
    assert sweep.held_out(tmp_path, 100, evaluate, reevaluate=True) == {"episodes": 100, "score": 3.5}
    assert len(made) == 3
