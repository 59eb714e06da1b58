"""The native trainer (``wolfpack train``, :mod:`wolfpack.learn`): tiny runs end to end (both
sides, MAPPO and IPPO), bit-identical reruns, resuming, its saved models driving ``opponent=``,
``wolfpack.load_policy`` and ``training/evaluate.py`` exactly as in training, and every bad
input refused with one line and nothing written."""

from __future__ import annotations

import csv
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import popen_interruptible, training_script

torch = pytest.importorskip("torch")

import wolfpack  # noqa: E402
from wolfpack.evaluation import HELD_OUT_SEED, report, rollout  # noqa: E402
from wolfpack.learn import recipe, train  # noqa: E402
from wolfpack.models import load_policy  # noqa: E402
from wolfpack.stats import iqm_interval  # noqa: E402

TRAINING = Path(__file__).resolve().parents[1] / "training"

#: A few updates in a few seconds: 8 worlds x 16 steps, short episodes.
TINY = {"num_envs": 8, "n_steps": 16, "epochs": 2, "minibatch_size": 64, "hidden": [16, 16]}
SHORT = {"world.max_steps": 40}


def tiny_train(out: Path, learners: str = "wolves", algo: str = "mappo", timesteps: int = 2_000, **kw):
    kw.setdefault("overrides", SHORT)
    kw.setdefault("hp", TINY)
    kw.setdefault("threads", 1)
    kw.setdefault("torch_threads", 1)
    kw.setdefault("eval_episodes", 4)
    return train(learners, algo, out=out, timesteps=timesteps, device="cpu", progress=False, **kw)


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def both_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("both_mappo")
    summary = tiny_train(out, "both", "mappo", timesteps=4_000, seed=1)
    return out, summary


def test_both_sides_mappo_run_writes_models_logs_checkpoints_and_evaluations(both_run):
    out, summary = both_run
    for name in ("config.yaml", "trainer.pt", "progress.csv", "evaluations.json", "summary.json"):
        assert (out / name).is_file(), name
    for side in ("wolves", "targets"):
        assert (out / side / "policy.pt").is_file() and (out / side / "config.yaml").is_file()
    assert list(out.glob("events.out.tfevents.*")), "TensorBoard log missing"
    assert list((out / "checkpoints").glob("*/wolves/policy.pt")), "no checkpoint"
    # 8 worlds x 16 steps x (5 wolves + 1 target) = 768 agent-steps per update; 4,000 -> 6 updates.
    assert summary["agent_steps"] == 6 * 768 and summary["updates"] == 6
    table = rows(out / "progress.csv")
    assert len(table) == 6
    for column in (
        "wall_s",
        "agent_steps",
        "agent_steps_per_s",
        "captured_rate",
        "collision_rate",
        "wolves_policy_loss",
        "targets_value_loss",
        "wolves_entropy",
        "targets_approx_kl",
        "eval_wolves_capture_rate",
        "eval_targets_capture_rate",
    ):
        assert column in table[0], column
    assert [int(r["agent_steps"]) for r in table] == [768 * k for k in range(1, 7)]
    assert all(float(r["agent_steps_per_s"]) > 0 for r in table)
    # The learning rate anneals linearly to 0 over the budget.
    lrs = [float(r["wolves_learning_rate"]) for r in table]
    assert lrs == sorted(lrs, reverse=True) and lrs[0] == pytest.approx(3e-4) and lrs[-1] < lrs[0]
    evaluations = json.loads((out / "evaluations.json").read_text())
    assert evaluations[-1]["agent_steps"] == summary["agent_steps"]
    assert evaluations[-1]["wolves"]["episodes"] == 4 and evaluations[-1]["targets"]["wolves"] == "seed000"


def test_mappo_critic_reads_the_state_and_ippo_does_not(tmp_path):
    env = wolfpack.BatchEnv(num_envs=1, seed=0, world__max_steps=40)
    from wolfpack.learn.ppo import SideLearner

    common = dict(obs_dim=env.wolf_obs_dim, state_dim=env.state_dim, agents=5, num_envs=2, device=torch.device("cpu"), generator=torch.Generator())
    r = recipe("wolves", "mappo", TINY)
    mappo = SideLearner("wolves", "mappo", r, **common)
    ippo = SideLearner("wolves", "ippo", r, **common)
    assert mappo.critic.body[0].in_features == env.state_dim + env.wolf_obs_dim
    assert ippo.critic.body[0].in_features == env.wolf_obs_dim
    with_ids = SideLearner("wolves", "ippo", recipe("wolves", "ippo", {**TINY, "agent_id": True}), **common)
    assert with_ids.actor.body[0].in_features == env.wolf_obs_dim + 5


def test_the_critic_projects_the_state_once_per_world_as_the_joined_input_would():
    from wolfpack.networks.mlp import Critic

    torch.manual_seed(0)
    for agent_id in (False, True):
        critic = Critic(obs_dim=7, state_dim=4, agents=3, hidden=[8, 8], activation="tanh", agent_id=agent_id, norm_obs=True)
        obs, state = torch.randn(6, 3, 7), torch.randn(6, 4)
        agent_in = critic.agent_inputs(obs)
        joined = torch.cat([state.unsqueeze(1).expand(6, 3, 4), agent_in], dim=-1)
        torch.testing.assert_close(critic.value(agent_in, state), critic.body(joined).squeeze(-1))


@pytest.mark.parametrize("algo", ["mappo", "ippo"])
@pytest.mark.parametrize("train_actor", [True, False], ids=["ppo", "critic-only"])
def test_the_actor_and_critic_learning_side_by_side_give_the_weights_of_one_thread(algo, train_actor):
    from wolfpack.learn.ppo import SideLearner

    r = recipe("wolves", algo, {**TINY, "clip_value": 0.2, "ent_coef": 0.01})
    learners = []
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        for side_by_side in (False, True):
            torch.manual_seed(3)
            gen = torch.Generator().manual_seed(4)
            learner = SideLearner("wolves", algo, r, obs_dim=9, state_dim=6, agents=5, num_envs=8, device=torch.device("cpu"), generator=gen, side_by_side=side_by_side)
            data = torch.Generator().manual_seed(5)
            rollout = learner.rollouts[0]
            for buffer in (rollout.obs, rollout.actions, rollout.values, rollout.advantages, rollout.returns) + ((rollout.state,) if rollout.state is not None else ()):
                buffer.normal_(generator=data)
            rollout.logp.normal_(generator=data).mul_(0.1).sub_(2.0)
            stats = [learner.update(train_actor=train_actor) for _ in range(2)]
            learners.append((learner, stats))
    finally:
        torch.set_num_threads(threads)
    (serial, serial_stats), (parallel, parallel_stats) = learners
    assert serial_stats == parallel_stats and serial_stats[0]["gradient_steps"] == 2 * (8 * 16 // (64 // 5))
    for (name, a), (_, b) in zip(serial.actor.state_dict().items(), parallel.actor.state_dict().items()):
        assert torch.equal(a, b), name
    for (name, a), (_, b) in zip(serial.critic.state_dict().items(), parallel.critic.state_dict().items()):
        assert torch.equal(a, b), name
    initial = SideLearner("wolves", algo, r, obs_dim=9, state_dim=6, agents=5, num_envs=8, device=torch.device("cpu"), generator=torch.Generator())
    assert torch.equal(serial.actor.log_std, initial.actor.log_std) != train_actor  # the actor learns only when asked


def test_ippo_targets_against_a_law_train_and_say_what_they_trained_against(tmp_path):
    summary = tiny_train(tmp_path / "t", "targets", "ippo", opponent="bvc")
    policy = load_policy(tmp_path / "t")
    assert policy.side == "targets" and policy.algo == "ippo" and policy.obs_dim == wolfpack.BatchEnv(learners="targets").target_obs_dim
    assert policy.params["policies"]["wolves"] == "bvc"
    assert summary["final_evaluation"]["targets"]["wolves"] == "bvc"


@pytest.mark.parametrize("torch_threads", [1, 2], ids=["one-torch-thread", "actor-and-critic-side-by-side"])
def test_a_rerun_with_the_same_seed_is_bit_identical_and_another_seed_is_not(tmp_path, torch_threads):
    def weights(out):
        return {k: v.numpy().copy() for k, v in torch.load(out / "wolves" / "policy.pt", weights_only=True).items()}

    tiny_train(tmp_path / "a", seed=5, torch_threads=torch_threads)
    tiny_train(tmp_path / "b", seed=5, torch_threads=torch_threads)
    tiny_train(tmp_path / "c", seed=6, torch_threads=torch_threads)
    a, b, c = weights(tmp_path / "a"), weights(tmp_path / "b"), weights(tmp_path / "c")
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert not all(np.array_equal(a[k], c[k]) for k in a)
    keep = ("captured_rate", "collision_rate", "wolves_policy_loss", "wolves_value_loss", "eval_wolves_capture_rate")
    ra, rb = rows(tmp_path / "a" / "progress.csv"), rows(tmp_path / "b" / "progress.csv")
    assert [[r[k] for k in keep] for r in ra] == [[r[k] for k in keep] for r in rb]


def test_resume_goes_on_from_the_saved_state(tmp_path):
    out = tmp_path / "run"
    first = tiny_train(out, timesteps=1_000)
    assert first["agent_steps"] == 2 * 640  # 8 worlds x 16 steps x 5 wolves per update
    before = load_policy(out)(np.zeros((5, before_dim()), np.float32))
    second = tiny_train(out, timesteps=4_000, resume=True)
    assert second["agent_steps"] == 7 * 640 and second["updates"] == 7
    table = rows(out / "progress.csv")
    assert [int(r["update"]) for r in table] == list(range(1, 8))  # appended, not restarted
    after = load_policy(out)(np.zeros((5, before_dim()), np.float32))
    assert not np.array_equal(before, after)


def before_dim() -> int:
    """A wolf's observation size under the wolves' recipes (they add the last sighting)."""
    return wolfpack.BatchEnv({"env": {"last_sighting": True}}, num_envs=1).wolf_obs_dim


def test_the_wolves_recipe_observes_the_last_sighting_and_the_run_can_say_otherwise(tmp_path):
    plain = wolfpack.BatchEnv(num_envs=1).wolf_obs_dim
    assert before_dim() == plain + 4
    tiny_train(tmp_path / "recipe", timesteps=700)
    model = load_policy(tmp_path / "recipe")
    assert model.obs_dim == plain + 4 and model.params["env"]["last_sighting"] is True
    assert model.params["rewards"]["wolves"]["collision_penalty"] == 30.0
    # As an opponent it switches the last sighting on in worlds whose params leave it off: the
    # targets learning there observe what they always did.
    batch = wolfpack.BatchEnv(num_envs=2, learners="targets", opponent=tmp_path / "recipe")
    assert batch.params["env"]["last_sighting"] is True and batch.target_obs_dim == wolfpack.BatchEnv(num_envs=1, learners="targets").target_obs_dim
    batch.reset(0)
    assert np.isfinite(batch.step(None, np.zeros((2, 1, 2), np.float32))["rewards_targets"]).all()
    tiny_train(tmp_path / "set", timesteps=700, overrides={**SHORT, "env.last_sighting": False})
    assert load_policy(tmp_path / "set").obs_dim == plain
    tiny_train(tmp_path / "hp", timesteps=700, hp={**TINY, "env.last_sighting": False})
    assert load_policy(tmp_path / "hp").obs_dim == plain


def test_saved_model_acts_as_the_trainer_did_and_drives_opponent_and_evaluation(both_run, tmp_path):
    out, summary = both_run
    wolves, targets = load_policy(out, "wolves"), load_policy(out, "targets")
    with pytest.raises(ValueError, match="each side"):
        load_policy(out)
    # The loader and the trainer's last evaluation agree exactly: same episodes, same outcomes.
    final = summary["final_evaluation"]["wolves"]
    params = wolves.params
    again = report(rollout(params, episodes=4, seed=HELD_OUT_SEED, wolves=wolves), wolves.name, "escape")
    for k in ("capture_rate", "collision_rate", "median_capture_steps", "mean_return_wolves"):
        assert again[k] == final[k], k
    # opponent= takes a side's model folder, or the run with the side said.
    batch = wolfpack.BatchEnv(params, num_envs=3, learners="wolves", seed=HELD_OUT_SEED, autoreset=False, opponent=out / "targets")
    assert batch.opponent.side == "targets" and batch.opponent.obs_dim == targets.obs_dim
    obs = batch.reset(HELD_OUT_SEED)
    via_opponent = wolfpack.Opponent(out, side="targets").act(batch._opponent_obs.reshape(-1, targets.obs_dim))
    assert np.array_equal(via_opponent, targets(batch._opponent_obs.reshape(-1, targets.obs_dim)))
    assert obs["obs_wolves"].shape == (3, 5, wolves.obs_dim)
    # Sampled actions repeat for a seeded generator and stay in the box.
    x = np.random.default_rng(0).standard_normal((10, wolves.obs_dim)).astype(np.float32)
    s1 = wolves.act(x, deterministic=False, rng=np.random.default_rng(3))
    s2 = wolves.act(x, deterministic=False, rng=np.random.default_rng(3))
    assert np.array_equal(s1, s2) and np.abs(s1).max() <= 1.0 and not np.array_equal(s1, wolves(x))


def test_training_evaluate_reads_a_run_of_both_sides(both_run, tmp_path):
    out, _ = both_run
    evaluate = training_script("evaluate")

    dest = tmp_path / "eval"
    assert evaluate.main(["--episodes", "3", "--seed", "0", "--set", "world.max_steps=40", "--out", str(dest), str(out)]) == 0
    doc = json.loads((dest / "results.json").read_text())
    labels = {(r["wolves"], r["targets"]) for r in doc["rows"]}
    name = out.name
    assert (f"mappo:{name}/wolves", "escape") in labels and ("seed000", f"mappo:{name}/targets") in labels
    matrix = tmp_path / "matrix"
    assert evaluate.main(["--matrix", "--episodes", "2", "--jobs", "1", "--set", "world.max_steps=40", "--out", str(matrix), str(out)]) == 0
    cells = json.loads((matrix / "matrix.json").read_text())["cells"]
    assert any(c["wolves"] == f"mappo:{name}/wolves" and c["targets"] == f"mappo:{name}/targets" for c in cells)


# --- bad input ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "args, message",
    [
        (["--side", "cats", "--out", "{out}", "--time-limit", "1"], "invalid choice: 'cats'"),
        (["--side", "wolves", "--algo", "qmix", "--out", "{out}", "--time-limit", "1"], "invalid choice: 'qmix'"),
        (["--side", "wolves", "--device", "tpu", "--out", "{out}", "--time-limit", "1"], "invalid choice: 'tpu'"),
        (["--side", "wolves", "--out", "{out}", "--time-limit", "0"], "--time-limit: must be a number of minutes > 0"),
        (["--side", "wolves", "--out", "{out}", "--time-limit", "nan"], "--time-limit: must be a number of minutes > 0"),
        (["--side", "wolves", "--out", "{out}"], "give a budget"),
        (["--side", "wolves", "--out", "{out}", "--time-limit", "1", "--hp", "learning_rat=1"], "--hp learning_rat: no such hyperparameter"),
        (["--side", "wolves", "--out", "{out}", "--time-limit", "1", "--hp", "gamma=2"], "--hp gamma: must be a number in [0, 1]"),
        (["--side", "wolves", "--out", "{out}", "--time-limit", "1", "--opponent", "seed000"], "'seed000' drives the wolves, but the wolves learn here"),
        (["--side", "wolves", "--out", "{out}", "--time-limit", "1", "--opponent", "nowhere/at/all"], "no model file there"),
        (["--side", "both", "--out", "{out}", "--time-limit", "1", "--opponent", "escape"], "no other side for it to drive"),
        (["--side", "wolves", "--out", "{out}", "--time-limit", "1", "--set", "world.wolvs=3"], "world.wolvs"),
        (["--side", "wolves", "--out", "{out}", "--time-limit", "1", "--resume"], "holds no run"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_nothing_written(cli, tmp_path, args, message):
    out = tmp_path / "run"
    result = cli("train", *[a.replace("{out}", str(out)) for a in args])
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and message in result.stderr, result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists()


@pytest.mark.skipif(torch.cuda.is_available(), reason="a CUDA device is present")
def test_cuda_where_there_is_none_is_refused(cli, tmp_path):
    result = cli("train", "--side", "wolves", "--out", tmp_path / "run", "--time-limit", "1", "--device", "cuda")
    assert result.returncode == 2 and "no CUDA device here" in result.stderr
    assert not (tmp_path / "run").exists()


def test_a_model_of_another_observation_size_or_side_is_refused(both_run, cli, tmp_path):
    out, _ = both_run
    # The wolves trained with 16 lidar rays; with 8 rays their observations are shorter.
    result = cli("train", "--side", "wolves", "--out", tmp_path / "a", "--time-limit", "1", "--opponent", out / "targets", "--set", "env.lidar.rays=8")
    assert result.returncode == 2 and "observations" in result.stderr and not (tmp_path / "a").exists(), result.stderr
    result = cli("train", "--side", "targets", "--out", tmp_path / "b", "--time-limit", "1", "--opponent", out / "targets")
    assert result.returncode == 2 and "the targets learn here" in result.stderr and not (tmp_path / "b").exists(), result.stderr


def test_an_existing_run_is_never_overwritten_and_resume_checks_the_configuration(tmp_path, cli):
    out = tmp_path / "run"
    tiny_train(out, timesteps=700)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    result = cli("train", "--side", "wolves", "--out", out, "--time-limit", "1")
    assert result.returncode == 2 and "not a new or empty folder" in result.stderr
    result = cli("train", "--side", "wolves", "--algo", "ippo", "--out", out, "--time-limit", "1", "--resume")
    assert result.returncode == 2 and "another algo" in result.stderr, result.stderr
    result = cli("train", "--side", "wolves", "--out", out, "--time-limit", "1", "--resume", "--set", "world.max_steps=50")
    assert result.returncode == 2 and "another params" in result.stderr, result.stderr
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before


def test_imitation_warm_start_clones_the_law_then_trains_with_ppo(tmp_path):
    import yaml

    out = tmp_path / "im"
    summary = train("wolves", "ippo", out=out, timesteps=2_000, imitate_min=0.05, overrides=SHORT, hp=TINY, threads=1, torch_threads=1, eval_episodes=4, device="cpu", progress=False)
    rounds = json.loads((out / "imitation.json").read_text())
    assert rounds[0]["beta"] == 1.0 and rounds[0]["samples"]["wolves"] == 8 * 16 * 5  # round 0: the law drives, every sample kept
    assert all(r["loss"]["wolves"] >= 0 for r in rounds)
    phases = [e["phase"] for e in json.loads((out / "evaluations.json").read_text())]
    assert phases[0] == "imitation" and set(phases[1:]) == {"ppo"}
    # The critic learns alone first: the actor's loss terms are not applied for 3 updates.
    table = rows(out / "progress.csv")
    assert summary["updates"] == len(table) >= 4
    assert yaml.safe_load((out / "config.yaml").read_text())["imitate_min"] == 0.05


def test_imitation_in_rounds_is_the_same_clone_however_busy_the_machine(tmp_path, monkeypatch):
    """--imitate-rounds: the rounds and the model do not depend on the clock (a run that took
    ten times longer, as on a loaded machine, clones and trains bit-identically)."""
    import time as time_module

    import torch
    import yaml

    def run(out, slow):
        if slow:
            start, real = time_module.perf_counter(), time_module.perf_counter
            monkeypatch.setattr(time_module, "perf_counter", lambda: start + 10 * (real() - start))
        train("wolves", "ippo", out=out, timesteps=1_000, imitate_rounds=3, overrides=SHORT, hp=TINY, threads=1, torch_threads=1, eval_episodes=2, device="cpu", progress=False)
        monkeypatch.undo()
        return json.loads((out / "imitation.json").read_text()), torch.load(out / "wolves" / "policy.pt", weights_only=False)

    rounds_a, model_a = run(tmp_path / "a", slow=False)
    rounds_b, model_b = run(tmp_path / "b", slow=True)
    assert [r["beta"] for r in rounds_a] == [r["beta"] for r in rounds_b] == [1.0, 0.5, 0.25]
    assert [r["loss"] for r in rounds_a] == [r["loss"] for r in rounds_b]
    assert model_a.keys() == model_b.keys() and all(torch.equal(model_a[k], model_b[k]) for k in model_a)
    assert yaml.safe_load((tmp_path / "a" / "config.yaml").read_text())["imitate_rounds"] == 3
    with pytest.raises(ValueError, match="--imitate-rounds"):
        train("wolves", "ippo", out=tmp_path / "c", timesteps=1_000, imitate_rounds=0, overrides=SHORT, hp=TINY, progress=False)
    assert not (tmp_path / "c").exists()


def test_a_run_starts_from_a_saved_model_with_its_recipe_and_a_critic_that_learns_first(tmp_path, monkeypatch):
    """--init: the learner starts with the model's actor and recipe; for the first updates only
    the critic learns, so after one update the actor's weights are still the model's (its
    observation normaliser goes on counting); later updates move it. The model is loaded once:
    the trainer takes the one that the run's checks loaded."""
    import wolfpack.learn.trainer
    import yaml

    def second_load(*args, **kwargs):
        raise AssertionError("the trainer loaded the --init model a second time")

    monkeypatch.setattr(wolfpack.learn.trainer, "load_policy", second_load)

    tiny_train(tmp_path / "a", algo="ippo", timesteps=1_000, hp={**TINY, "hidden": [24, 24], "learning_rate": 1e-3})
    model = torch.load(tmp_path / "a" / "wolves" / "policy.pt", weights_only=True)
    weights = [k for k in model if not k.startswith("norm.")]
    assert len(weights) >= 6

    # One update (8 worlds x 16 steps x 5 wolves = 640 agent-steps), no --hp: the model's recipe.
    tiny_train(tmp_path / "b", algo="ippo", timesteps=640, hp={}, init=str(tmp_path / "a"))
    started = torch.load(tmp_path / "b" / "wolves" / "policy.pt", weights_only=True)
    assert all(torch.equal(started[k], model[k]) for k in weights)
    assert not torch.equal(started["norm.count"], model["norm.count"]), "the normaliser counts the new run's observations"
    config = yaml.safe_load((tmp_path / "b" / "wolves" / "config.yaml").read_text())
    assert config["recipe"]["hidden"] == [24, 24] and config["recipe"]["learning_rate"] == 1e-3
    assert config["init"] == str(tmp_path / "a" / "wolves")
    assert yaml.safe_load((tmp_path / "b" / "config.yaml").read_text())["init"] == {"wolves": str(tmp_path / "a" / "wolves")}

    tiny_train(tmp_path / "c", algo="ippo", timesteps=640 * 5, hp={}, init=str(tmp_path / "a" / "wolves"))
    moved = torch.load(tmp_path / "c" / "wolves" / "policy.pt", weights_only=True)
    assert not all(torch.equal(moved[k], model[k]) for k in weights), "PPO moves the actor after the critic's first updates"


def test_a_start_from_a_model_that_does_not_fit_is_refused_before_anything_is_written(tmp_path, both_run):
    run, _ = both_run
    bad = [
        (dict(init=str(tmp_path)), "not a model of 'wolfpack train'"),
        (dict(learners="targets", init=str(run / "wolves")), "a model of the wolves, and this run trains the targets"),
        (dict(init=[str(run), str(run / "wolves")]), "a second model of the wolves"),
        (dict(init=str(run), imitate_rounds=2), "--init and --imitate both"),
        (dict(init=str(run), hp={"hidden": [32, 32]}), "another network than this run's (hidden: [16, 16] there, [32, 32] here)"),
    ]
    for k, (kw, message) in enumerate(bad):
        out = tmp_path / f"out{k}"
        with pytest.raises(ValueError) as err:
            tiny_train(out, **kw)
        assert message in str(err.value), str(err.value)
        assert not out.exists()
    r = subprocess.run(
        [sys.executable, "-m", "wolfpack", "train", "--side", "targets", "--init", str(run / "wolves"), "--timesteps", "100", "--out", str(tmp_path / "cli")], capture_output=True, text=True
    )
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "--init" in r.stderr, r.stderr
    assert not (tmp_path / "cli").exists()


def test_imitation_fits_the_actor_to_the_law(tmp_path):
    """A few rounds on a tiny batch bring the clone's actions closer to the law's than the
    untrained actor's were, on states the law itself visits."""
    from wolfpack.learn.imitation import imitate
    from wolfpack.learn.trainer import Trainer, TrainSpec

    params = wolfpack.load_params(overrides=SHORT)
    spec = TrainSpec(learners="wolves", algo="ippo", params=params, recipes={"wolves": recipe("wolves", "ippo", {**TINY, "num_envs": 32, "hidden": [64, 64]})}, threads=1, torch_threads=1, timesteps=1)
    trainer = Trainer(spec, tmp_path / "t", progress=False)
    probe = wolfpack.BatchEnv(params, num_envs=16, seed=77, threads=1)
    out = probe.reset()
    obs, expert = out["obs_wolves"], probe.expert_actions()[0]

    def error():
        return float(np.mean((trainer.learners["wolves"].policy()(obs) - np.clip(expert, -1, 1)) ** 2))

    before = error()
    rounds = imitate(trainer, 1.0, lambda: 0.0, max_rounds=4)  # a clock that stands still: four whole rounds
    assert [r["beta"] for r in rounds] == [1.0, 0.5, 0.25, 0.125]
    assert error() < 0.7 * before, (before, error())


def test_seeds_report_gives_the_interquartile_mean_with_a_bootstrap_interval(tmp_path):
    seeds = training_script("seeds")

    s = iqm_interval([0.1, 0.2, 0.3, 0.4, 1.0])
    assert s["iqm"] == pytest.approx(0.3)  # the middle three of five: the outlier 1.0 does not move it
    assert s["median"] == 0.3 and (s["min"], s["max"]) == (0.1, 1.0)
    assert 0.1 <= s["ci95"][0] <= 0.3 <= s["ci95"][1] <= 1.0 and s["ci95"][0] < s["ci95"][1]
    assert iqm_interval([0.5, 0.5])["ci95"] == [0.5, 0.5]
    runs = [tmp_path / f"s{k}" for k in range(2)]
    for k, run in enumerate(runs):
        tiny_train(run, seed=k, timesteps=700)
    dest = tmp_path / "report"
    assert seeds.main(["--episodes", "3", "--against", "random", "--out", str(dest), *map(str, runs)]) == 0
    doc = json.loads((dest / "seeds.json").read_text())
    assert set(doc["opponents"]) == {"escape", "random"} and doc["opponents"]["escape"]["skill"]["n"] == 2
    assert (dest / "curves.png").is_file() and "IQM" in (dest / "seeds.md").read_text()


def test_ctrl_c_stops_promptly_and_keeps_the_models(tmp_path):
    import signal
    import subprocess
    import time

    out = tmp_path / "run"
    proc = popen_interruptible(
        [
            sys.executable,
            "-m",
            "wolfpack.cli",
            "train",
            "--side",
            "wolves",
            "--time-limit",
            "30",
            "--threads",
            "1",
            "--torch-threads",
            "1",
            "--hp",
            "num_envs=8",
            "--hp",
            "n_steps=16",
            "--hp",
            "minibatch_size=64",
            "--eval-episodes",
            "2",
            "--out",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not ((out / "progress.csv").is_file() and len(rows(out / "progress.csv")) >= 2):
        time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    last = stderr.strip().splitlines()[-1]
    assert last.startswith(f"wolfpack: interrupted; {out} holds the models and the resume state at ") and last.endswith("continue with --resume") and stdout == ""
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stopped_by"] == "interrupt" and summary["updates"] >= 2
    assert load_policy(out).obs_dim == before_dim()


def test_the_recipes_of_both_sides_may_not_set_one_params_key_differently():
    from wolfpack.learn.recipes import recipes_params_overrides

    wolves, targets = recipe("wolves", "mappo"), recipe("targets", "mappo")
    merged = recipes_params_overrides({"wolves": wolves, "targets": targets})
    assert merged["env.last_sighting"] is True and merged["rewards.wolves.collision_penalty"] == 30.0
    targets["env"] = {"last_sighting": False}
    with pytest.raises(ValueError, match=r"the recipes of both sides set env.last_sighting differently \(True, False\)"):
        recipes_params_overrides({"wolves": wolves, "targets": targets})


def test_an_opponent_pool_draws_every_member_reproducibly_and_evaluates_the_first(both_run, tmp_path, monkeypatch):
    trained_targets = str(both_run[0] / "targets")
    drawn: list[list[str]] = []

    def recording(set_opponent):
        def wrapper(self, opponent):
            drawn[-1].append(getattr(opponent, "name", str(opponent)))
            return set_opponent(self, opponent)

        return wrapper

    monkeypatch.setattr(wolfpack.BatchEnv, "set_opponent", recording(wolfpack.BatchEnv.set_opponent))
    pool = ["escape", "still", trained_targets]
    # The both-sides run's targets saw the plain wolves' observations; so do these wolves.
    plain = {**SHORT, "env.last_sighting": False}
    for run in ("a", "b"):
        drawn.append([])
        summary = tiny_train(tmp_path / run, timesteps=8_000, opponent=pool, overrides=plain, seed=3)
    assert drawn[0] == drawn[1] and len(drawn[0]) == summary["updates"] - 1
    assert {"escape", "still"} <= set(drawn[0]) and any(name not in ("escape", "still") for name in drawn[0])
    assert summary["final_evaluation"]["wolves"]["targets"] == "escape"
    model = load_policy(tmp_path / "a")
    assert model.config["opponent"] == "escape" and model.config["opponent_pool"] == pool


def test_every_pool_member_is_checked_before_anything_is_written(both_run, cli, tmp_path):
    out, _ = both_run
    result = cli("train", "--side", "wolves", "--out", tmp_path / "a", "--time-limit", "1", "--opponent", "escape", "--opponent", "bvc")
    assert result.returncode == 2 and "'bvc' drives the wolves" in result.stderr and not (tmp_path / "a").exists(), result.stderr
    # The both-sides run's targets see 16 lidar rays; with 8 rays the pool's second member does not fit.
    result = cli("train", "--side", "wolves", "--out", tmp_path / "b", "--time-limit", "1", "--opponent", "escape", "--opponent", out / "targets", "--set", "env.lidar.rays=8")
    assert result.returncode == 2 and "observations" in result.stderr and not (tmp_path / "b").exists(), result.stderr


def test_a_training_run_asks_torch_openmp_to_wait_passively_unless_the_user_chose():
    # In a fresh interpreter (torch not yet imported): the run sets the policy before torch
    # loads, and leaves a user's own choice alone.
    code = "import os, sys\nfrom wolfpack.learn.run import prefer_passive_omp\nprefer_passive_omp()\nprint(os.environ.get('OMP_WAIT_POLICY'))\n"
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    fresh = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert fresh.stdout.strip() == "PASSIVE"
    chosen = subprocess.run([sys.executable, "-c", code], env={**env, "OMP_WAIT_POLICY": "ACTIVE"}, capture_output=True, text=True, check=True)
    assert chosen.stdout.strip() == "ACTIVE"


def test_a_training_run_keeps_freed_minibatch_memory_in_the_heap_unless_the_user_chose():
    # glibc reports memory held in separate mappings (mallinfo2's hblkhd): a 4 MB block is one by
    # default, and comes from the heap once training asked malloc to keep its freed memory. A
    # user's own MALLOC_*_ variables are left alone (nothing changed, the default stays).
    if platform.system() != "Linux" or not platform.libc_ver()[0] == "glibc":
        pytest.skip("mallopt is glibc's")
    code = (
        "import ctypes, sys\n"
        "from wolfpack.learn.run import keep_freed_memory\n"
        "class Info(ctypes.Structure):\n"
        "    _fields_ = [(n, ctypes.c_size_t) for n in ('arena', 'ordblks', 'smblks', 'hblks', 'hblkhd', 'usmblks', 'fsmblks', 'uordblks', 'fordblks', 'keepcost')]\n"
        "libc = ctypes.CDLL(None)\n"
        "libc.mallinfo2.restype = Info\n"
        "changed = keep_freed_memory() if sys.argv[1] == 'keep' else None\n"
        "before = libc.mallinfo2().hblkhd\n"
        "block = bytearray(4 << 20)\n"
        "print(changed, libc.mallinfo2().hblkhd - before >= 4 << 20)\n"
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    run = lambda which, **extra: subprocess.run([sys.executable, "-c", code, which], env={**env, **extra}, capture_output=True, text=True, check=True).stdout.split()  # noqa: E731
    assert run("default") == ["None", "True"]
    assert run("keep") == ["True", "False"]
    assert run("keep", MALLOC_TRIM_THRESHOLD_="131072", MALLOC_MMAP_THRESHOLD_="131072") == ["False", "True"]


def test_every_training_option_is_a_command_line_option_of_the_same_name():
    """wolfpack train's parser writes TrainOptions' field names, so that the command line and
    wolfpack.learn.train() take one list of options (a new field without an option fails here)."""
    from dataclasses import fields

    from wolfpack.cli.main import build_parser
    from wolfpack.learn import TrainOptions

    args = build_parser().parse_args(["train", "--side", "wolves", "--out", "x", "--timesteps", "10", "--imitate", "2", "--imitate-rounds", "3", "--time-limit", "5"])
    computed = {"progress", "command"}  # from --no-progress, and the command line itself
    assert {f.name for f in fields(TrainOptions)} - computed <= set(vars(args))
    assert (args.learners, args.time_limit_min, args.imitate_min, args.imitate_rounds) == ("wolves", 5.0, 2.0, 3)
    with pytest.raises(TypeError, match="timestep"):
        train(out="x", timestep=10)


def test_a_leagues_models_are_named_by_the_league_and_the_step():
    """A league's runs are named after their side (``<league>/iter3/wolves``): its models are
    labelled with the league and the step, where any other run is labelled by its folder."""
    from wolfpack.models import native_label

    def label(run: str, learners: str = "wolves") -> str:
        return native_label(Path("."), {"algo": "mappo", "run": run, "learners": learners, "side": "wolves"})

    assert label("/x/runs/league-a/iter3/wolves") == "mappo:league-a/iter3/wolves"
    assert label("/x/runs/league-a/final/targets") == "mappo:league-a/final/targets"
    assert label("/x/runs/wolves") == "mappo:wolves"
    assert label("/x/runs/pool") == "mappo:pool"
    assert label("/x/runs/both", "both") == "mappo:both/wolves"
