"""One model over entity observations and several tasks: the set network's invariances, a tiny
multi-task run end to end, its determinism, one model on 3, 5 and 8 wolves, the
generalisation track, and every bad input of these surfaces."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

import wolfpack  # noqa: E402
from wolfpack.learn import train  # noqa: E402
from wolfpack.learn.tasks import VARIANTS, parse_vary  # noqa: E402
from wolfpack.models import load_policy  # noqa: E402
from wolfpack.networks.sets import EntityNorm, SetNet, encode_mean_max, row_encoder  # noqa: E402
from wolfpack.scorecard import as_policy, best_law, load_baselines, scorecard  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TINY = {"num_envs": 8, "n_steps": 16, "epochs": 2, "minibatch_size": 64, "hidden": [16, 16], "entity_width": 8, "heads": 2, "network": "entities"}
SHORT = {"world.max_steps": 40}
F = len(wolfpack.ENTITY_FIELDS)


def tiny(out: Path, tasks, timesteps: int = 3_000, **kw):
    kw.setdefault("overrides", SHORT)
    kw.setdefault("hp", TINY)
    kw.setdefault("eval_episodes", 2)
    kw.setdefault("evaluations", 1)
    return train("wolves", "mappo", out=out, task=tasks, timesteps=timesteps, device="cpu", progress=False, threads=1, torch_threads=1, seed=kw.pop("seed", 0), **kw)


def obs_with_rows(rows: np.ndarray, own: int = 7) -> np.ndarray:
    """An entity observation: ``own`` own features then ``rows`` [R, F]."""
    return np.concatenate([np.linspace(-1, 1, own), rows.ravel()]).astype(np.float32)


@pytest.mark.parametrize("pool", ["mean_max", "attention"])
def test_the_set_network_ignores_row_order_and_padding(pool):
    torch.manual_seed(0)
    net = SetNet(7, F, 16, [16], 2, "tanh", pool, 4, 1.0)
    rng = np.random.default_rng(1)
    rows = rng.normal(size=(5, F)).astype(np.float32)
    rows[:, 0] = 1.0
    x = torch.from_numpy(obs_with_rows(rows))
    shuffled = torch.from_numpy(obs_with_rows(rows[rng.permutation(5)]))
    padded = torch.from_numpy(obs_with_rows(np.concatenate([rows, np.zeros((6, F), np.float32)])))
    with torch.no_grad():
        a, b, c = net(x), net(shuffled), net(padded)
    torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-6)
    torch.testing.assert_close(a, c, rtol=1e-5, atol=1e-6)
    # A row that is present does change the output.
    more = rows.copy()
    more[0, 5] += 1.0
    assert not torch.allclose(a, net(torch.from_numpy(obs_with_rows(more))).detach())


def test_the_fused_row_pooling_matches_autograd_through_relu_mean_and_max():
    # encode_mean_max has a hand-written backward: it must give autograd's values and
    # gradients (for the weight and the rows; the row count is a constant, not a path) on rows
    # with padding and a world with none present.
    torch.manual_seed(0)
    rows = torch.randn(6, 5, F, dtype=torch.float64)
    rows[:, :, 0] = (torch.rand(6, 5) < 0.6).double()
    rows[:, 0, 0] = 1.0
    rows[5, :, 0] = 0.0  # a world whose rows are all padding
    rows.mul_(rows[:, :, :1])
    encoder = row_encoder(F, 8).double()
    grad = torch.randn(6, 16, dtype=torch.float64)

    def reference(r):
        e = torch.relu(encoder(r))
        return torch.cat([e.sum(1) / r[:, :, :1].detach().sum(1).clamp(min=1.0), e.amax(1)], -1)

    outputs, grads = [], []
    for fn in (reference, lambda r: encode_mean_max(r, encoder)):
        encoder.zero_grad()
        r = rows.clone().requires_grad_(True)
        out = fn(r)
        out.backward(grad)
        outputs.append(out.detach())
        grads.append((encoder.weight.grad.clone(), r.grad.clone()))
    torch.testing.assert_close(outputs[1], outputs[0])
    torch.testing.assert_close(grads[1][0], grads[0][0])
    torch.testing.assert_close(grads[1][1], grads[0][1])
    assert grads[0][0].abs().sum() > 0 and outputs[0][5].abs().sum() == 0


def test_dropping_empty_slots_changes_no_action_and_no_batch_mate_changes_one():
    # The set encoder skips the slots that are padding everywhere in its batch (and the update
    # drops those of a whole rollout): a world's output must be the same bits whichever other
    # worlds share its batch and whether the rollout was compacted.
    batch = wolfpack.BatchEnv(task="hunt-v1", num_envs=16, learners="wolves", seed=3, **{"env.observation": "entities"})
    out = batch.reset()
    rng = np.random.default_rng(0)
    for _ in range(5):
        out = batch.step(rng.uniform(-1, 1, size=(16, batch.n_wolves, 2)).astype(np.float32))
    x = torch.from_numpy(out["obs_wolves"].copy())  # [16 worlds, 5 wolves, D]
    walls = 4
    own = x.shape[-1] - (walls + 18) * F
    torch.manual_seed(0)
    net = SetNet(own, F, 16, [16], 2, "tanh", "mean_max", 4, 1.0, wall_rows=walls)
    compact = net.walls.without_empty_slots(x)
    assert compact.shape[-1] < x.shape[-1], "hunt-v1's wolves leave slots empty (5 wolves, 1 target)"
    with torch.no_grad():
        full = net(x)
        assert torch.equal(net(compact), full)
        # A world alone (with its 5 wolves) against the same world among 16: other worlds' rows
        # decide which slots are encoded, never the values.
        crowded = x[:4].clone()  # worlds whose every slot holds a row
        rows = crowded[..., own:].reshape(4, batch.n_wolves, -1, F)
        rows[:] = rows[:, :, :1]
        together = net(torch.cat([crowded, x[4:]]))
        assert torch.equal(together[4:], full[4:])
        assert torch.equal(net(x[4:8]), full[4:8])
        # A batch where no slot holds a row (only the walls) keeps one slot to pool over.
        empty = x.clone()
        empty[..., own : x.shape[-1] - walls * F] = 0.0
        assert net.walls.without_empty_slots(empty).shape[-1] == x.shape[-1] - 17 * F
        assert torch.equal(net(net.walls.without_empty_slots(empty)), net(empty))


def test_the_entity_normaliser_counts_present_rows_only_and_keeps_padding_zero():
    norm = EntityNorm(3, F)
    rows = np.zeros((4, F), np.float32)
    rows[:2, 0] = 1.0
    rows[:2, 5] = [2.0, 4.0]
    x = torch.from_numpy(np.stack([obs_with_rows(rows, own=3)] * 8))
    norm.accumulate(x)
    norm.commit()
    assert float(norm.rows.mean[0]) == pytest.approx(3.0), "the padding rows' zeros are not counted"
    y = norm(x).reshape(8, -1)[:, 3:].reshape(8, 4, F)
    assert (y[:, 2:] == 0).all() and (y[:, :, :5] == x[:, 3:].reshape(8, 4, F)[:, :, :5]).all()
    # The present rows' field 5 (2 and 4: mean 3, variance 1) is standardised in place.
    torch.testing.assert_close(y[0, :2, 5], torch.tensor([-1.0, 1.0]), rtol=0, atol=1e-4)


@pytest.fixture(scope="module")
def multi_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("multi")
    summary = tiny(out, ["hunt-v1", "small-pack-v1", "two-targets-v1"])
    return out, summary


def test_a_multi_task_run_logs_each_task_and_saves_one_model(multi_run):
    out, summary = multi_run
    # 8 worlds split 3 / 3 / 2 over the tasks: 3 x 5 + 3 x 3 + 2 x 5 = 34 wolves, x 16 steps.
    assert summary["agent_steps"] % (34 * 16) == 0 and summary["agent_steps"] >= 3_000
    with open(out / "progress.csv", newline="") as f:
        table = list(csv.DictReader(f))
    for task in ("hunt-v1", "small-pack-v1", "two-targets-v1"):
        assert table[-1][f"eval_{task}_wolves_capture_rate"] != "", task
        assert f"weight_{task}" in table[0]
    policy = load_policy(out)
    assert policy.config["network"]["kind"] == "entities"
    assert set(policy.entity_kinds) == {"wolf", "target", "obstacle", "wall"}


@pytest.mark.parametrize("wolves", [3, 5, 8])
def test_one_model_plays_packs_of_any_size(multi_run, wolves):
    out, _ = multi_run
    batch = wolfpack.BatchEnv(num_envs=2, learners="none", opponent=as_policy(str(out), "wolves"), seed=3, **{"world.wolves": wolves, "world.targets": 2})
    batch.reset()
    for _ in range(5):
        step = batch.step()
    assert batch.n_wolves == wolves and np.isfinite(step["rewards_wolves"]).all()


def test_the_scorecard_plays_every_task_with_an_entity_model(multi_run):
    out, _ = multi_run
    card = scorecard(str(out), "wolves", episodes=2)
    assert card["tasks_played"] == list(card["tasks"]) and len(card["tasks"]) == 7


def test_a_flat_escaper_plays_against_an_entity_pack():
    escaper = ROOT / "results" / "learned" / "targets_mappo" / "native_targets_mappo_s0"
    batch = wolfpack.BatchEnv(num_envs=2, learners="wolves", opponent=str(escaper), **{"env.wolf_observation": "entities"})
    out = batch.reset()
    out = batch.step(np.zeros((2, batch.n_wolves, 2), np.float32))
    assert out["obs_wolves"].shape[-1] == batch.wolf_obs_dim != load_policy(escaper).obs_dim


def test_a_multi_task_run_is_deterministic(tmp_path):
    a = tiny(tmp_path / "a", ["hunt-v1", "small-pack-v1"], timesteps=1_500, seed=5)
    b = tiny(tmp_path / "b", ["hunt-v1", "small-pack-v1"], timesteps=1_500, seed=5)
    assert a["agent_steps"] == b["agent_steps"]
    wa, wb = (torch.load(p / "wolves" / "policy.pt", weights_only=True) for p in (tmp_path / "a", tmp_path / "b"))
    for key in wa:
        torch.testing.assert_close(wa[key], wb[key], rtol=0, atol=0)


@pytest.mark.parametrize("mode", ["adaptive", "shortfall"])
def test_task_weights_follow_the_last_held_out_evaluation(tmp_path, mode):
    # After the mid-run evaluation, each task weighs by its failure rate (adaptive) or by how
    # far it is below the task's best committed law (shortfall), plus 0.05, scaled to mean 1:
    # taking two targets, which the best law does 28 % of the time, must then weigh less than
    # hunt-v1, which it takes 97.5 % of the time, when the learner fails both.
    tasks = ["hunt-v1", "two-targets-v1"]
    tiny(tmp_path, tasks, timesteps=6_000, task_weights=mode, evaluations=2, eval_episodes=4)
    first = json.loads((tmp_path / "evaluations.json").read_text())[0]
    score = {t: first["tasks"][t]["wolves"]["capture_rate"] for t in tasks}
    laws = load_baselines()
    need = {t: (best_law(laws, "wolves", t)[1] - score[t] if mode == "shortfall" else 1.0 - score[t]) for t in tasks}
    raw = [max(0.0, need[t]) + 0.05 for t in tasks]
    expected = [w / (sum(raw) / len(raw)) for w in raw]
    rows = list(csv.DictReader((tmp_path / "progress.csv").open()))
    after = [r for r in rows if int(r["agent_steps"]) > first["agent_steps"]]
    assert after and all(float(r["weight_hunt-v1"]) == 1.0 for r in rows if r not in after)
    for r in after:
        assert [float(r[f"weight_{t}"]) for t in tasks] == pytest.approx(expected, rel=1e-5)
    if mode == "shortfall" and score["two-targets-v1"] < 0.2:
        assert expected[1] < expected[0]


def test_vary_draws_each_group_within_its_range(tmp_path):
    from wolfpack.batch import resolve_params
    from wolfpack.learn.tasks import world_groups

    groups, evals = world_groups(["hunt-v1"], parse_vary(["world.wolves=3:8", "agents.target.v_max=1.2:1.8"]), 0, lambda t, extra: resolve_params(None, extra, t))
    assert len(groups) == VARIANTS and [t for t, _ in evals] == ["hunt-v1"]
    for _, task, params in groups:
        assert task == "hunt-v1" and 3 <= params["world"]["wolves"] <= 8 and 1.2 <= params["agents"]["target"]["v_max"] <= 1.8


def test_the_generalisation_track_ranks_a_policy_among_the_laws():
    card = scorecard("seed000", "wolves", track="generalisation", tasks=["pack-4", "arena-30"], episodes=2)
    assert card["track"] == "generalisation" and list(card["tasks"]) == ["pack-4", "arena-30"]
    for row in card["tasks"].values():
        assert set(row["baselines"]) == {"bvc", "formation"} and 1 <= row["rank"] <= 3


def test_a_model_that_never_met_obstacles_skips_the_tasks_that_have_them(tmp_path):
    tiny(tmp_path / "open", "open-v1", timesteps=600)
    card = scorecard(str(tmp_path / "open"), "wolves", tasks=["open-v1", "hunt-v1"], episodes=2)
    assert "score" in card["tasks"]["open-v1"]
    assert card["tasks"]["hunt-v1"]["skipped"] == "it never met obstacle rows in training"


def cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "wolfpack", *args], cwd=cwd, capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--task", "hunt-v9"], "--task 'hunt-v9': no such task"),
        (["--task", "hunt-v1", "--vary", "world.wolves=3:2000"], "world.wolves"),
        (["--task", "hunt-v1", "--vary", "world.wolves=8:3"], "lower bound 8 exceeds"),
        (["--task", "hunt-v1", "--vary", "world.wolves"], "expected KEY=LO:HI"),
        (["--task", "hunt-v1", "--vary", "world.nothing=1:2"], "world.nothing"),
        (["--vary", "world.wolves=3:5"], "--vary needs --task"),
        (["--task", "hunt-v1", "--task", "small-pack-v1", "--hp", "network=mlp"], "network=entities"),
        (["--task", "hunt-v1", "--hp", "agent_id=true"], "agent_id"),
        (["--task", "hunt-v1", "--set", "world.wolves=9"], "env.entities.max_wolves"),
    ],
)
def test_bad_multi_task_input_is_one_line_and_writes_nothing(tmp_path, args, message):
    out = tmp_path / "run"
    hp = [] if "network=mlp" in args else ["--hp", "network=entities"]
    proc = cli("train", "--side", "wolves", "--timesteps", "1000", "--out", str(out), "--no-progress", *hp, *args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], proc.stderr
    assert not out.exists()


def test_imitation_warms_up_a_multi_task_pack_on_every_task(tmp_path):
    summary = tiny(tmp_path / "imitated", ["hunt-v1", "small-pack-v1"], timesteps=1_000, imitate_min=0.02)
    rounds = json.loads((tmp_path / "imitated" / "imitation.json").read_text())
    assert rounds and rounds[0]["beta"] == 1.0 and rounds[0]["samples"]["wolves"] > 0
    # Both tasks' worlds gave labels: 16 steps of 4 worlds of 5 wolves and 4 of 3.
    assert rounds[0]["samples"]["wolves"] == 16 * (4 * 5 + 4 * 3)
    assert summary["agent_steps"] >= 1_000


@pytest.mark.slow  # two runs of the report script over every task: 18 s
def test_the_generalist_report_scores_every_run_and_draws_curves_only_from_multi_task_runs(multi_run, tmp_path):
    """training/generalist.py over a multi-task run and a run of one task (as a fine-tuning
    league's final pack is): both scored on every task; the per-task curves need every run to
    have been evaluated per task, so with the one-task run there are none, and a note says so."""
    multi, _ = multi_run
    single = tmp_path / "single"
    tiny(single, ["hunt-v1"], timesteps=600)
    script = ROOT / "training" / "generalist.py"

    def report(out: Path, *runs: Path) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, str(script), "--episodes", "2", "--out", str(out), *map(str, runs)], capture_output=True, text=True, timeout=600)

    both = report(tmp_path / "both", multi, single)
    assert both.returncode == 0, both.stderr
    doc = json.loads((tmp_path / "both" / "generalist.json").read_text())
    assert len(doc["scorecards"]) == 2 and doc["tasks"]["hunt-v1"]["captured"]["n"] == 2
    assert not (tmp_path / "both" / "curves.png").exists() and "no curves.png" in both.stderr
    alone = report(tmp_path / "alone", multi)
    assert alone.returncode == 0, alone.stderr
    assert (tmp_path / "alone" / "curves.png").is_file()
