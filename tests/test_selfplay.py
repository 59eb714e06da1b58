"""training/selfplay.py end to end on a tiny budget (members, league file, resume, refusals) and
evaluate.py --matrix (scripted cells equal ``wolfpack hunt`` exactly, models in their own action
modes, league folders, the robustness column, files)."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

from conftest import training_script  # noqa: E402
from wolfpack import cli  # noqa: E402
from wolfpack.evaluation import report  # noqa: E402
from wolfpack.learn.matches import play  # noqa: E402
from wolfpack.learn.sb3 import env_params, load_model  # noqa: E402
from wolfpack.learn.selfplay import PFSP_FLOOR, sampling_weights, win_rate  # noqa: E402

evaluate = training_script("evaluate")
selfplay = training_script("selfplay")

MODELS = Path(__file__).resolve().parents[1] / "results" / "models"
#: Two or three updates of the trainer per generation (4 worlds x 16 steps x 5 wolves = 320
#: agent-steps per update of the wolves, 4 x 16 x 1 = 64 of the targets).
TINY = [
    "--timesteps",
    "640",
    "--hp",
    "n_steps=16",
    "--hp",
    "minibatch_size=64",
    "--hp",
    "epochs=1",
    "--hp",
    "hidden=[16, 16]",
    "--num-envs-wolves",
    "4",
    "--num-envs-targets",
    "4",
    "--threads",
    "1",
    "--torch-threads",
    "1",
    "--eval-episodes",
    "3",
    "--no-progress",
    "--set",
    "world.max_steps=60",
]


@pytest.fixture(scope="module")
def league(tmp_path_factory):
    out = tmp_path_factory.mktemp("league")
    argv = ["--out", str(out), "--generations", "2", "--fixed-wolves", "seed000,bvc", "--fixed-targets", "escape", "--member", str(MODELS / "escape_ppo"), "--pool-sampling", "uniform", *TINY]
    assert selfplay.main(argv) == 0
    return out


def test_selfplay_builds_a_league_of_frozen_members(league):
    doc = json.loads((league / "league.json").read_text())
    names = [m["name"] for m in doc["members"]]
    assert names == ["seed000", "bvc", "escape", "escape_ppo", "targets_g01", "wolves_g02"]
    assert [g["side"] for g in doc["generations"]] == ["targets", "wolves"]
    # Every learned member is a model that training's loader (and so opponent=) accepts.
    for m in doc["members"]:
        if m["kind"] == "model" and not m.get("fixed"):
            loaded = load_model(league / m["path"])
            assert loaded.side == m["side"] and loaded.algo == "mappo" and m["timesteps"] >= 640
            assert loaded.label == f"mappo:{m['name']}" and (league / m["state"]).is_file()
    # The fixed members were measured against each other, then each new member against the
    # whole other side: every (wolf, target) pair once.
    pairs = [(e["wolves"], e["targets"]) for e in doc["evaluations"]]
    assert len(pairs) == len(set(pairs))
    wolves = [m["name"] for m in doc["members"] if m["side"] == "wolves"]
    targets = [m["name"] for m in doc["members"] if m["side"] == "targets"]
    assert set(pairs) == {(w, t) for w in wolves for t in targets}
    g1 = doc["generations"][0]
    assert set(g1["opponents_drawn"]) <= {"seed000", "bvc"} and sum(g1["opponents_drawn"].values()) >= 1
    assert "targets_g01" in doc["generations"][1]["weights"] and "escape_ppo" in doc["generations"][1]["weights"]
    assert "| wolves_g02 |" in (league / "league.md").read_text()
    assert (league / "league_curves.png").stat().st_size > 10_000
    assert (league / "generations" / "01" / "progress.csv").is_file()


def test_selfplay_refuses_to_overwrite_and_resumes(league, capsys):
    assert selfplay.main(["--out", str(league), "--generations", "3", *TINY]) == 2
    assert "already holds a league" in capsys.readouterr().err
    before = json.loads((league / "league.json").read_text())
    # The league keeps its scenario and recipe: --resume takes neither --set nor --hp.
    assert selfplay.main(["--out", str(league), "--resume", "--generations", "3", "--hp", "epochs=2"]) == 2
    assert "no --params/--set/--hp" in capsys.readouterr().err
    again = [a for i, a in enumerate(TINY) if a not in ("--set", "--hp") and (i == 0 or TINY[i - 1] not in ("--set", "--hp"))]
    assert selfplay.main(["--out", str(league), "--resume", "--generations", "3", *again]) == 0
    after = json.loads((league / "league.json").read_text())
    assert after["members"][: len(before["members"])] == before["members"]
    assert after["members"][-1]["name"] == "targets_g03" and after["generations"][-1]["started_from"] == "targets_g01"
    assert len(after["commands"]) == 2


def test_prioritised_sampling_meets_the_opponents_it_loses_to():
    league = {"evaluations": [{"wolves": "w", "targets": "easy", "capture_rate": 1.0}, {"wolves": "w", "targets": "hard", "capture_rate": 0.1}]}
    pool = [{"name": "easy", "generation": 0}, {"name": "hard", "generation": 0}, {"name": "new", "generation": 3}]
    easy, hard, new = sampling_weights(league, "wolves", "w", pool, "prioritised")
    assert easy == pytest.approx(PFSP_FLOOR) and hard == pytest.approx(0.81 + PFSP_FLOOR) and new == pytest.approx(0.25 + PFSP_FLOOR)
    assert sampling_weights(league, "wolves", "w", pool, "latest") == [0.0, 0.0, 1.0]
    assert sampling_weights(league, "wolves", "w", pool, "uniform") == [1.0, 1.0, 1.0]
    # A target member's win rate is its survival rate.
    assert win_rate(league, "hard", "targets", "w") == pytest.approx(0.9)


def test_selfplay_bad_arguments_exit_2(tmp_path, capsys):
    assert selfplay.main(["--out", str(tmp_path / "a"), "--resume"]) == 2
    assert "no league.json" in capsys.readouterr().err
    assert selfplay.main(["--out", str(tmp_path / "b"), "--init-wolves", str(tmp_path / "nothing")]) == 2
    assert "no such model" in capsys.readouterr().err
    # An SB3 model is a model, but no trainer's state to start a generation from.
    assert selfplay.main(["--out", str(tmp_path / "b2"), "--init-targets", str(MODELS / "escape_ppo")]) == 2
    assert "not a run of wolfpack train (no trainer.pt)" in capsys.readouterr().err and not (tmp_path / "b2" / "league.json").exists()
    with pytest.raises(SystemExit):
        selfplay.main(["--out", str(tmp_path / "c"), "--fixed-wolves", "seed000,wolfish"])
    assert "unknown wolves law 'wolfish'" in capsys.readouterr().err


def matrix(argv: list[str]) -> dict:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert evaluate.main(["--matrix", "--json", *argv]) == 0
    return json.loads(buf.getvalue())


def test_matrix_scripted_cells_equal_wolfpack_hunt_exactly(capsys):
    doc = matrix(["--episodes", "30", "--seed", "4", "--jobs", "2"])
    assert doc["wolves"] == ["seed000", "bvc", "formation"] and doc["targets"] == ["escape", "random", "still"]
    by = {(c["wolves"], c["targets"]): c for c in doc["cells"]}
    for w, t in [("seed000", "escape"), ("bvc", "random"), ("formation", "escape")]:
        cli.main(["hunt", "--wolves", w, "--targets", t, "--episodes", "30", "--seed", "4", "--json"])
        hunt = json.loads(capsys.readouterr().out)
        for key in ("episodes", "capture_rate", "collision_rate", "timeout_rate", "median_capture_steps", "mean_energy", "cornered_rate"):
            assert by[(w, t)][key] == hunt[key], (w, t, key)
    rob = doc["robustness"]
    for w in doc["wolves"]:
        assert rob["wolves"][w]["worst_capture_rate"] == min(by[(w, t)]["capture_rate"] for t in doc["targets"])
    for t in doc["targets"]:
        assert rob["targets"][t]["worst_survival_rate"] == pytest.approx(1 - max(by[(w, t)]["capture_rate"] for w in doc["wolves"]))


def test_matrix_with_models_and_a_league(league, tmp_path):
    out = tmp_path / "mx"
    assert evaluate.main(["--matrix", "--episodes", "6", "--jobs", "1", "--out", str(out), "--set", "world.max_steps=60", str(MODELS / "wolves_ft"), str(MODELS / "escape_ppo"), str(league)]) == 0
    doc = json.loads((out / "matrix.json").read_text())
    # The league folder adds the members it trained (not escape_ppo, which it borrowed).
    trained = [f"mappo:{m['name']}" for m in json.loads((league / "league.json").read_text())["members"] if m["kind"] == "model" and not m.get("fixed")]
    assert doc["wolves"] == ["seed000", "bvc", "formation", "ppo:wolves_ft", *[t for t in trained if "wolves" in t]]
    assert doc["targets"] == ["escape", "random", "still", "ppo:escape_ppo", *[t for t in trained if "targets" in t]]
    assert len(doc["cells"]) == len(doc["wolves"]) * len(doc["targets"]) and (out / "matrix.png").stat().st_size > 20_000
    assert "worst case (capture)" in (out / "matrix.md").read_text()
    # A model's cell is the model in its own action mode (wolves_ft: velocity) against the law:
    # the same episodes as driving it by hand through play.
    ft = load_model(MODELS / "wolves_ft")
    base = env_params(None, ["world.max_steps=60"])
    want = report(play(base, ft, "escape", episodes=6, seed=0), ft.label, "escape")
    cell = next(c for c in doc["cells"] if c["wolves"] == "ppo:wolves_ft" and c["targets"] == "escape")
    assert cell["capture_rate"] == want["capture_rate"] and cell["mean_energy"] == want["mean_energy"]


def test_matrix_refuses_a_model_that_does_not_fit(capsys):
    assert evaluate.main(["--matrix", "--episodes", "2", "--set", "env.lidar.rays=8", str(MODELS / "wolves_ft")]) == 2
    err = capsys.readouterr().err
    assert "50" in err and "42" in err
