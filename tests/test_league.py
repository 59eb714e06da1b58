"""Population training (``wolfpack league``, :mod:`wolfpack.learn.league`): the Nash meta-solver,
a tiny league of both sides end to end, resuming it, and bad input."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("scipy")

from wolfpack.learn.league import META_SEED, LeagueError, league, pool  # noqa: E402
from wolfpack.learn.meta import mixtures, nash  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: Two iterations of one update per run (the targets' recipe: 8,192 agent-steps an update; the
#: wolves' one update is more), both sides' runs of a step at once.
TINY = dict(iterations=2, budget=8_192, episodes=4, jobs=2)


def wolfpack_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "wolfpack", *args], capture_output=True, text=True, cwd=ROOT)


def test_the_meta_solver_solves_known_games():
    # Rock-paper-scissors (payoffs 0, 1/2, 1): the uniform mixture for both, value 1/2.
    rps = np.array([[0.5, 0.0, 1.0], [1.0, 0.5, 0.0], [0.0, 1.0, 0.5]])
    x, y, value = nash(rps)
    np.testing.assert_allclose(x, [1 / 3] * 3, atol=1e-9)
    np.testing.assert_allclose(y, [1 / 3] * 3, atol=1e-9)
    assert value == pytest.approx(0.5)
    # A saddle point: each side's pure strategy, and the value in between.
    x, y, value = nash(np.array([[0.9, 0.8], [0.2, 0.1]]))
    assert x.tolist() == [1.0, 0.0] and y.tolist() == [0.0, 1.0] and value == pytest.approx(0.8)
    # Matching pennies with a dominated third row: no weight on it.
    x, y, value = nash(np.array([[1.0, 0.0], [0.0, 1.0], [0.4, 0.4]]))
    np.testing.assert_allclose(x, [0.5, 0.5, 0.0], atol=1e-9)
    assert value == pytest.approx(0.5)
    with pytest.raises(ValueError, match="finite, non-empty"):
        nash(np.array([[np.nan]]))


def test_the_uniform_meta_solver_weighs_every_member_alike(tmp_path):
    m = np.array([[0.9, 0.8], [0.2, 0.1], [0.5, 0.5]])
    x, y, value = mixtures(m, "uniform")
    np.testing.assert_allclose(x, [1 / 3] * 3)
    np.testing.assert_allclose(y, [0.5, 0.5])
    assert value == pytest.approx(m.mean())
    x, y, value = mixtures(m, "nash")
    assert x.tolist() == [1.0, 0.0, 0.0] and value == pytest.approx(0.8)
    with pytest.raises(ValueError, match="meta-solver 'pfsp': one of nash, uniform"):
        mixtures(m, "pfsp")
    with pytest.raises(LeagueError, match="--meta-solver 'pfsp'"):
        league(tmp_path / "out", meta_solver="pfsp")
    with pytest.raises(LeagueError, match="--fine-tune 'wolf': both, wolves or targets"):
        league(tmp_path / "out", fine_tune="wolf")
    assert not (tmp_path / "out").exists()


def test_a_mixture_becomes_the_trainers_pool_in_twentieths():
    assert pool(["a", "b", "c"], np.array([0.5, 0.25, 0.25])) == ["a"] * 10 + ["b"] * 5 + ["c"] * 5
    assert pool(["a", "b"], np.array([0.99, 0.01])) == ["a"] * 20
    assert pool(["a", "b"], np.array([0.0, 1.0])) == ["b"] * 20


@pytest.fixture(scope="module")
def tiny_league(tmp_path_factory):
    out = tmp_path_factory.mktemp("league") / "run"
    seen = []
    doc = league(out, progress=seen.append, **TINY)
    return out, doc, seen


@pytest.mark.slow  # whole leagues: a minute in all
def test_a_league_of_both_sides_runs_end_to_end(tiny_league):
    out, doc, seen = tiny_league
    assert json.loads((out / "league.json").read_text()) == json.loads(json.dumps(doc))
    assert [r["iteration"] for r in doc["history"]] == [1, 2] and len(seen) == 2
    # The populations start from the task's laws and grow by one best response per side.
    assert doc["wolves"] == ["seed000"] and doc["targets"] == ["escape"]
    assert [r["population"] for r in doc["history"]] == [{"wolves": 1, "targets": 1}, {"wolves": 2, "targets": 2}]
    assert doc["payoffs"]["wolves"] == ["seed000", "iter1/wolves/wolves", "iter2/wolves/wolves"]
    payoffs = json.loads((out / "payoffs.json").read_text())
    m = np.array(doc["payoffs"]["capture_rate"])
    assert m.shape == (3, 3)
    for record in doc["history"]:
        assert sum(record["mixtures"]["wolves"].values()) == pytest.approx(1.0)
        ex, br, value = record["exploitability"], record["best_response_rates"], record["value"]
        assert ex == {"wolves": pytest.approx(1 - min(br["targets"], value)), "targets": pytest.approx(max(br["wolves"], value))}
        assert record["nash_conv"] == pytest.approx(ex["targets"] - (1 - ex["wolves"]))
        for side in ("wolves", "targets"):
            run = out / Path(record["best_responses"][side]["model"]).parent
            config = (run / "config.yaml").read_text()
            assert "--opponent" in config and (run / side / "policy.pt").is_file()
    # The final policies were trained against the final mixtures, and their value is the game's.
    x, y, value = nash(m)
    assert doc["final"]["value"] == pytest.approx(value)
    for side in ("wolves", "targets"):
        assert (out / doc["final"]["policies"][side]["model"] / "policy.pt").is_file()
    # Every payoff is a capture rate on the meta-game's episodes, the same as a rollout's.
    assert payoffs["seed000 | escape"] == m[0, 0]
    from wolfpack.evaluation import report, rollout
    from wolfpack.task import task_params

    assert report(rollout(task_params("hunt-v1"), episodes=4, seed=META_SEED), "seed000", "escape")["capture_rate"] == m[0, 0]


@pytest.mark.slow  # whole leagues: a minute in all
@pytest.mark.parametrize("fine_tune", [True, "wolves"])
def test_a_fine_tuning_league_starts_each_run_from_the_sides_newest_model(tmp_path, fine_tune):
    """--fine-tune: the wolves' runs continue the pack the league started from, then its newest
    best response; the targets' first run (a population of laws) starts from scratch, and with
    --fine-tune wolves every one of the targets' runs does."""
    import yaml

    start = str(ROOT / "results" / "learned" / "wolves_mappo" / "native_wolves_mappo_s0" / "wolves")
    out = tmp_path / "tuned"
    doc = league(out, iterations=1, budget=8_192, episodes=4, jobs=2, wolves=[start], fine_tune=fine_tune)
    assert doc["fine_tune"] == fine_tune and doc["wolves"] == [start]

    def init(run: str) -> str | None:
        return yaml.safe_load((out / run / "config.yaml").read_text()).get("init")

    assert init("iter1/wolves") == {"wolves": start}
    assert init("iter1/targets") is None
    assert init("final/wolves") == {"wolves": str(out / "iter1" / "wolves" / "wolves")}
    assert init("final/targets") == ({"targets": str(out / "iter1" / "targets" / "targets")} if fine_tune is True else None)
    # The fine-tuned pack keeps the network it started from (a best response from scratch would
    # have the wolves' default recipe).
    model = yaml.safe_load((out / "iter1" / "wolves" / "wolves" / "config.yaml").read_text())
    assert model["network"] == yaml.safe_load((Path(start) / "config.yaml").read_text())["network"]


@pytest.mark.slow  # whole leagues: a minute in all
def test_a_stopped_league_resumes_and_ends_as_an_uninterrupted_one(tiny_league, tmp_path):
    out, doc, _ = tiny_league
    # Stopped during the second iteration: its targets' run never started, the final not either.
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    for gone in ("league.json", "iter2/targets", "final"):
        path = copy / gone
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    payoffs = json.loads((copy / "payoffs.json").read_text())
    (copy / "payoffs.json").write_text(json.dumps({k: v for k, v in payoffs.items() if "iter2" not in k}))
    kept = (copy / "iter2" / "wolves" / "summary.json").stat().st_mtime_ns
    # The stopped invocation had recorded its wall time up to its first iteration.
    progress = json.loads((copy / "progress.json").read_text())
    (copy / "progress.json").write_text(json.dumps({"finished": False, "history": progress["history"][:1], "wall_s": 1000.0}))
    r = wolfpack_cli("league", "--out", str(copy), "--iterations", "2", "--budget", "8192", "--episodes", "4", "--jobs", "2", "--resume", "--json")
    assert r.returncode == 0, r.stderr
    again = json.loads(r.stdout)
    assert (copy / "iter2" / "wolves" / "summary.json").stat().st_mtime_ns == kept, "a finished run is read back"
    assert 1000.0 < again["wall_s"] < 1000.0 + 600, "the earlier invocation's wall time is counted"

    def without_times(d):
        if isinstance(d, dict):
            return {k: without_times(v) for k, v in d.items() if k not in ("train_s", "wall_s")}
        return [without_times(v) for v in d] if isinstance(d, list) else d

    assert without_times(again) == without_times(doc)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--budget", "0"], "--budget: must be >= 1"),
        (["--iterations", "0"], "--iterations: must be >= 1"),
        (["--jobs", "3"], "--jobs: must be <= 2"),
        (["--wolves", "escape"], "--wolves escape: it plays the targets, not the wolves"),
        (["--targets", str(ROOT / "results" / "learned" / "wolves_mappo" / "native_wolves_mappo_s0")], "it plays the wolves, not the targets"),
        (["--wolves", "nosuch"], "--wolves nosuch: opponent 'nosuch': not a scripted law"),
        (["--meta-solver", "pfsp"], "--meta-solver: invalid choice: 'pfsp' (choose from 'nash', 'uniform')"),
        (["--fine-tune", "wolf"], "--fine-tune: invalid choice: 'wolf' (choose from 'both', 'wolves', 'targets')"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, message):
    out = tmp_path / "out"
    r = wolfpack_cli("league", "--out", str(out), *args)
    assert r.returncode == 2 and message in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not out.exists()


@pytest.mark.slow  # whole leagues: a minute in all
def test_a_finished_league_or_another_configuration_is_not_resumed(tiny_league, tmp_path):
    out, _, _ = tiny_league
    base = ["league", "--iterations", "2", "--budget", "8192", "--episodes", "4"]
    r = wolfpack_cli(*base, "--out", str(out), "--resume")
    assert r.returncode == 2 and "is finished (league.json is there)" in r.stderr, r.stderr
    r = wolfpack_cli(*base, "--out", str(out))
    assert r.returncode == 2 and "not a new or empty folder" in r.stderr, r.stderr
    unfinished = tmp_path / "unfinished"
    shutil.copytree(out, unfinished)
    (unfinished / "league.json").unlink()
    r = wolfpack_cli("league", "--iterations", "3", "--budget", "8192", "--episodes", "4", "--out", str(unfinished), "--resume")
    assert r.returncode == 2 and "is a league of another configuration (iterations: 2 there)" in r.stderr, r.stderr
