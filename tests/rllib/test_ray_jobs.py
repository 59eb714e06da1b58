"""The best-response jobs of ``wolfpack exploit`` and ``wolfpack league`` on Ray
(``--cluster``): two local Ray workers give exactly the results of two child processes here
(the same runs, with the same threads each: a run is bit-identical given its seed and thread
counts).

Runs in the RLlib virtualenv (``bash tests/rllib/run.sh``), which has ray; Ray stays on loopback
(``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, set by run.sh and below).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")

ray = pytest.importorskip("ray")
pytest.importorskip("torch")

from wolfpack.learn.exploit import exploitability  # noqa: E402
from wolfpack.learn.league import league  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
#: Two best responses of one update each (the targets' recipe: 8,192 agent-steps an update).
TINY = dict(budgets=[8_192], seeds=2, episodes=4)


def without_times(d):
    if isinstance(d, dict):
        return {k: without_times(v) for k, v in d.items() if k not in ("train_s", "wall_s")}
    return [without_times(v) for v in d] if isinstance(d, list) else d


def test_two_ray_workers_give_the_exploitability_of_one_machine(tmp_path):
    here = exploitability("bvc", "wolves", tmp_path / "here", jobs=2, **TINY)
    seen = []
    on_ray = exploitability("bvc", "wolves", tmp_path / "ray", jobs=2, cluster="local", progress=seen.append, **TINY)
    assert not ray.is_initialized(), "the Ray started for the job is stopped after it"
    assert without_times(on_ray) == without_times(here)
    assert sorted(row["seed"] for row in seen) == [0, 1]
    for row in on_ray["budgets"][0]["per_seed"]:
        assert (tmp_path / "ray" / row["model"] / "policy.pt").is_file()


def test_a_league_on_ray_is_the_league_of_one_machine(tmp_path, monkeypatch):
    """A fine-tuning league from a committed pack named by a relative path: the Ray workers run
    where the job was started, so the paths its options name are found."""
    monkeypatch.chdir(REPO)
    tiny = dict(iterations=1, budget=8_192, episodes=4, wolves=["results/learned/wolves_mappo/native_wolves_mappo_s0/wolves"], fine_tune=True)
    here = league(tmp_path / "here", jobs=2, **tiny)
    on_ray = league(tmp_path / "ray", jobs=2, cluster="local", **tiny)
    assert without_times(on_ray) == without_times(here)


def test_an_empty_cluster_address_is_one_line_and_writes_nothing(tmp_path):
    out = tmp_path / "x"
    r = subprocess.run(
        [sys.executable, "-m", "wolfpack", "exploit", "--wolves", "bvc", "--budget", "8192", "--seeds", "1", "--cluster", "", "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "--cluster" in r.stderr, r.stderr
    assert not out.exists()
