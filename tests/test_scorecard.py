"""``wolfpack benchmark`` and :mod:`wolfpack.scorecard`: a policy on every task, ranked against
the committed baselines."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import wolfpack
from wolfpack import scorecard
from wolfpack.evaluation import HELD_OUT_SEED
from wolfpack.task import TASK_ORDER, task_params

ROOT = Path(__file__).resolve().parents[1]
WOLF_MODEL = ROOT / "results" / "models" / "wolves_ft"  # SB3, 5 wolves


def _cli(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "wolfpack", "benchmark", *argv], capture_output=True, text=True, cwd=ROOT)


def test_a_law_scores_what_wolfpack_hunt_counts_on_the_same_episodes():
    card = scorecard.scorecard("bvc", "wolves", tasks=["open-v1", "fast-target-v1"], episodes=12, seed=40)
    for task in ("open-v1", "fast-target-v1"):
        results = wolfpack.run_episodes(task_params(task, {"policies.wolves": "bvc"}), 12, 40)
        assert card["tasks"][task]["score"] == sum(r["outcome"] == "captured" for r in results) / 12
        lo, hi = card["tasks"][task]["score_ci95"]
        assert lo <= card["tasks"][task]["score"] <= hi
    assert card["side"] == "wolves" and card["skill"] == "capture_rate" and card["tasks_played"] == ["open-v1", "fast-target-v1"]


def test_two_targets_report_how_far_the_pack_got():
    """With two targets a failed episode may still have taken one: ``any_capture_rate`` and
    ``mean_targets_captured`` count the targets captured in each episode, whatever its outcome,
    as ``wolfpack.run_episodes`` records each target's capture step."""
    row = scorecard.score_task(scorecard.as_policy("bvc", "wolves"), "wolves", "two-targets-v1", episodes=24, seed=40)
    results = wolfpack.run_episodes(task_params("two-targets-v1", {"policies.wolves": "bvc"}), 24, 40)
    taken = [sum(step is not None for step in r["target_capture_steps"]) for r in results]
    assert row["any_capture_rate"] == sum(k > 0 for k in taken) / 24
    assert row["mean_targets_captured"] == pytest.approx(sum(taken) / 24)
    assert row["any_capture_rate"] > row["capture_rate"]  # some episodes took one target only
    card = scorecard.scorecard("bvc", "wolves", tasks=["open-v1", "two-targets-v1"], episodes=24, seed=40)
    text = scorecard.markdown(card)
    assert f"`two-targets-v1` (2 targets): at least one taken in {100 * row['any_capture_rate']:.1f} % of episodes" in text
    assert "`open-v1` (" not in text  # one target: a capture is the whole story


def test_targets_are_scored_on_survival():
    card = scorecard.scorecard("still", "targets", tasks=["hunt-v1"], episodes=10, seed=0)
    results = wolfpack.run_episodes(task_params("hunt-v1", {"policies.targets": "still"}), 10, 0)
    assert card["tasks"]["hunt-v1"]["score"] == sum(r["outcome"] != "captured" for r in results) / 10
    assert "| target collisions | timeouts |" in scorecard.markdown(card)


def test_ranks_count_the_baselines_that_scored_higher_and_never_the_policy_itself():
    fake = {
        "episodes": 6,
        "first_seed": 0,
        "wolves": {
            "seed000": {"kind": "law", "tasks": {"open-v1": {"score": 2.0}}},  # above anything real
            "bvc": {"kind": "law", "tasks": {"open-v1": {"score": -1.0}}},
            "other": {"kind": "law", "tasks": {"open-v1": {"score": 1.5}}},
        },
        "targets": {},
    }
    card = scorecard.scorecard("bvc", "wolves", tasks=["open-v1"], episodes=6, seed=0, baselines=fake)
    row = card["tasks"]["open-v1"]
    assert row["baselines"] == {"seed000": 2.0, "other": 1.5}
    assert (row["rank"], row["ranked_among"]) == (3, 3)
    # Other episodes than the baselines': nothing is ranked.
    card = scorecard.scorecard("bvc", "wolves", tasks=["open-v1"], episodes=5, seed=0, baselines=fake)
    assert card["ranked_against"] is None and card["tasks"]["open-v1"]["rank"] is None


def test_a_callable_plays_every_task_it_fits():
    calls = []

    def still_wolves(obs: np.ndarray) -> np.ndarray:
        calls.append(obs.shape)
        return np.full((obs.shape[0], 2), -1.0, np.float32)  # v = 0

    card = scorecard.scorecard(still_wolves, "wolves", tasks=["small-pack-v1"], episodes=3, seed=0)
    assert card["tasks"]["small-pack-v1"]["score"] == 0.0 and calls


def test_a_model_skips_the_tasks_of_another_observation_size_and_says_why():
    card = scorecard.scorecard(str(WOLF_MODEL), "wolves", tasks=["open-v1", "small-pack-v1"], episodes=2, seed=0)
    assert "score" in card["tasks"]["open-v1"]
    assert card["tasks"]["small-pack-v1"] == {"skipped": "it takes 50 observations, the wolves of small-pack-v1 have 40"}
    assert card["tasks_played"] == ["open-v1"]
    with pytest.raises(ValueError, match="fits none of the tasks"):
        scorecard.scorecard(str(WOLF_MODEL), "wolves", tasks=["small-pack-v1"], episodes=2)


def test_a_policy_of_the_other_side_is_refused():
    with pytest.raises(ValueError, match="law of the targets, not of the wolves"):
        scorecard.scorecard("escape", "wolves", tasks=["hunt-v1"], episodes=1)
    with pytest.raises(ValueError, match="unknown task"):
        scorecard.scorecard("bvc", "wolves", tasks=["hunt-v0"], episodes=1)


def _laws(entries: dict) -> set[str]:
    return {name for name, entry in entries.items() if entry["kind"] == "law"}


def test_the_committed_baselines_cover_every_task_and_reproduce():
    base = scorecard.load_baselines()
    assert (base["episodes"], base["first_seed"]) == (scorecard.DEFAULT_EPISODES, HELD_OUT_SEED)
    assert _laws(base["wolves"]) == {"seed000", "bvc", "formation"} and _laws(base["targets"]) == {"escape", "random", "still"}
    for side in ("wolves", "targets"):
        for name in _laws(base[side]):
            assert list(base[side][name]["tasks"]) == list(TASK_ORDER)
    # The learned baselines join their side's ranking on the tasks they were trained on.
    assert {"ippo-wolves", "mappo-wolves"} <= set(base["wolves"]) and "mappo-escaper" in base["targets"]
    assert "hunt-v1" in base["wolves"]["mappo-wolves"]["tasks"]
    # The laws are deterministic on these episodes: one row, rerun, is the very number.
    card = scorecard.scorecard("seed000", "wolves", tasks=["open-v1"])
    assert card["tasks"]["open-v1"]["score"] == base["wolves"]["seed000"]["tasks"]["open-v1"]["score"]
    others = [name for name, entry in base["wolves"].items() if name != "seed000" and "open-v1" in entry["tasks"]]
    assert card["tasks"]["open-v1"]["ranked_among"] == len(others) + 1 >= 5


def test_learned_baselines_rank_by_the_iqm_of_their_seeds_on_the_same_episodes(tmp_path):
    laws = {"episodes": 6, "first_seed": 0, "wolves": {"seed000": {"kind": "law", "tasks": {"open-v1": {"score": 0.9}}}}, "targets": {}}
    learned = {
        "episodes": 6,
        "first_seed": 0,
        "learners": {"ippo-wolves": {"side": "wolves", "algo": "ippo"}, "mappo-escaper": {"side": "targets", "algo": "mappo"}},
        "summary": {"open-v1": {"ippo-wolves": {"iqm": 2.0, "ci95": [1.5, 2.5], "n": 5}, "mappo-escaper": {"iqm": 0.7, "ci95": [0.6, 0.8], "n": 5}}},
    }
    (tmp_path / "laws.json").write_text(json.dumps(laws))
    (tmp_path / "learned.json").write_text(json.dumps(learned))
    base = scorecard.load_baselines(tmp_path / "laws.json", tmp_path / "learned.json")
    assert base["wolves"]["ippo-wolves"] == {"kind": "learned", "tasks": {"open-v1": {"score": 2.0, "score_ci95": [1.5, 2.5], "seeds": 5}}}
    assert base["targets"]["mappo-escaper"]["tasks"]["open-v1"]["score"] == 0.7
    card = scorecard.scorecard("bvc", "wolves", tasks=["open-v1"], episodes=6, seed=0, baselines=base)
    row = card["tasks"]["open-v1"]
    assert row["baselines"] == {"seed000": 0.9, "ippo-wolves": 2.0}
    assert row["rank"] >= 2 and row["ranked_among"] == 3
    assert card["baseline_kinds"] == {"seed000": "law", "ippo-wolves": "learned"}
    # Learners scored on other episodes than the laws' are not comparable: left out.
    (tmp_path / "learned.json").write_text(json.dumps({**learned, "first_seed": 1}))
    base = scorecard.load_baselines(tmp_path / "laws.json", tmp_path / "learned.json")
    assert set(base["wolves"]) == {"seed000"} and base["targets"] == {}


def test_benchmark_writes_a_scorecard_json_markdown_and_figure(tmp_path):
    out = tmp_path / "card"
    run = _cli("--wolves", "seed000", "--tasks", "hunt-v1", "open-v1", "--episodes", "4", "--out", str(out))
    assert run.returncode == 0, run.stderr
    card = json.loads((out / "scorecard.json").read_text())
    assert list(card["tasks"]) == ["hunt-v1", "open-v1"] and card["command"].startswith("wolfpack benchmark --wolves seed000")
    table = (out / "scorecard.md").read_text()
    assert "| `hunt-v1` |" in table and "| `open-v1` |" in table and run.stdout.startswith("# Scorecard: seed000 (wolves)")
    assert "| wolf collisions | timeouts |" in table
    assert (out / "scorecard.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--wolves", "escape"], "law of the targets, not of the wolves"),
        (["--targets", "bvc"], "law of the wolves, not of the targets"),
        (["--wolves", "seed000", "--targets", "escape"], "not allowed with argument"),
        ([], "one of the arguments --wolves --targets is required"),
        (["--wolves", "no/such/model"], "no/such/model"),
        (["--wolves", "bvc", "--tasks", "hunt-v7"], "unknown task 'hunt-v7'"),
        (["--wolves", "bvc", "--episodes", "0"], "--episodes"),
        (["--wolves", "bvc", "--set", "capture.distanc=1.0"], "capture.distanc"),
        (["--wolves", "bvc", "--set", "world.wolves=-3"], "world.wolves: must be an integer"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, message):
    run = _cli(*argv)
    assert run.returncode == 2, run.stderr
    assert message in run.stderr and len(run.stderr.strip().splitlines()) == 1


def test_an_occupied_out_folder_is_refused_and_kept(tmp_path):
    (tmp_path / "keep.txt").write_text("mine")
    run = _cli("--wolves", "seed000", "--tasks", "hunt-v1", "--episodes", "1", "--out", str(tmp_path))
    assert run.returncode == 2 and "not a new or empty folder" in run.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_overrides_play_every_task_modified_and_unranked():
    # The baselines' own episodes (200 from the held-out seed), so only the overrides stop the ranking.
    card = scorecard.scorecard("bvc", "wolves", tasks=["hunt-v1", "open-v1"], episodes=200, seed=HELD_OUT_SEED, overrides={"capture.distance": 1.0})
    for task in ("hunt-v1", "open-v1"):
        results = wolfpack.run_episodes(task_params(task, {"policies.wolves": "bvc", "capture.distance": 1.0}), 200, HELD_OUT_SEED)
        assert card["tasks"][task]["score"] == sum(r["outcome"] == "captured" for r in results) / 200
        assert card["tasks"][task]["rank"] is None
    assert card["modified_task"] and card["ranked_against"] is None and card["overrides"] == {"capture.distance": 1.0}
    table = scorecard.markdown(card)
    assert table.startswith("# Scorecard: bvc (wolves) on modified tasks\n") and "`capture.distance` changes the world" in table
    # A learner's observation is no modification of the task, but the baselines did not play with it either.
    card = scorecard.scorecard("bvc", "wolves", tasks=["hunt-v1"], episodes=200, overrides={"env.last_sighting": True})
    assert not card["modified_task"] and card["ranked_against"] is None
    assert scorecard.markdown(card).startswith("# Scorecard: bvc (wolves)\n")
    assert scorecard.scorecard("bvc", "wolves", tasks=["hunt-v1"], episodes=200)["ranked_against"] == "committed baselines"


def test_a_bad_override_writes_nothing(tmp_path):
    out = tmp_path / "card"
    run = _cli("--wolves", "bvc", "--set", "world.targets=0", "--out", str(out))
    assert run.returncode == 2 and "world.targets" in run.stderr and not out.exists()
