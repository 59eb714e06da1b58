"""Train wolves or targets with Stable-Baselines3 on wolfpack's native VecEnv.

    python training/train.py --side targets --algo ppo --timesteps 2000000 --seed 0 --out runs/escape
    python training/train.py --side wolves --algo ppo --timesteps 3000000 --seed 0 \\
        --out runs/wolves_ft --init-from runs/wolves_bc

The other side follows its scripted law (params ``policies.*``; default seed000 wolves, escape
target), and all agents of the learning side share one policy (one VecEnv slot per agent per
world). Timesteps count agent-steps, as SB3 does: a vector step of W worlds with N learning
wolves is W·N timesteps.

Writes into --out (created if missing):
  config.yaml          side, algo, params (resolved), hyperparameters, seeds, command, versions —
                       written first; evaluate.py and --init-from read it
  model.zip            the final model (SB3 ``PPO.load``/``SAC.load``)
  best_model.zip       the model with the best held-out mean return so far
  checkpoints/         model_<timesteps>_steps.zip every --checkpoint-freq timesteps (default: a
                       fifth of --timesteps, and with --time-limit also every fifth of the
                       limit), at the next rollout boundary: never the same parameters twice
  progress.csv, events.out.tfevents.*   SB3's logs (CSV and TensorBoard: tensorboard --logdir DIR)
  evaluations.json     the held-out evaluations (capture rate with its 95 % interval, capture
                       steps, returns, ...) every --eval-freq timesteps (default: a tenth of
                       --timesteps, and with --time-limit also every tenth of the limit), at
                       the next rollout boundary (PPO: every n_steps × slots timesteps at most)
  learning_curve.png   held-out capture rate and training return against timesteps
  train_summary.json   wall time; time inside the environment and its share of training (held-out
                       evaluations excluded); rollout collection vs gradient updates; throughput;
                       the final held-out evaluation

Held-out evaluation uses episodes HELD_OUT_SEED + k (500000 + k), never seen in training (training
worlds are seeded 1000000·(seed+1) + e); evaluate.py's default seeds 0.. are disjoint from both.
Hyperparameters: wolfpack/learn/sb3_hyperparams.yaml, overridable with --hp key=value. Bad arguments exit
with status 2 and one line on stderr.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

import yaml
from wolfpack.cli.args import int_at_least
from wolfpack.evaluation import HELD_OUT_SEED, TRAIN_SEED_BASE, report, rollout
from wolfpack.learn.sb3 import HYPERPARAMS_PATH, SB3_ALGOS, Stopwatch, algorithms, env_params, hyperparams, load_model, observation_size, prepare_out, sb3_kwargs, versions, write_config
from wolfpack.models import MODEL_FILE
from wolfpack.sides import SIDES

#: The SB3 hyperparameters: each algorithm's section, and its fine-tuning section.


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="train.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--side", required=True, choices=SIDES, help="which side learns; the other follows its scripted law")
    p.add_argument("--algo", default="ppo", choices=SB3_ALGOS, help="SB3 algorithm (default ppo)")
    p.add_argument("--timesteps", required=True, type=int_at_least(1), help="training budget in agent-steps")
    p.add_argument("--params", default=None, help="params YAML (default: the documented scenario, or with --init-from the source run's params)")
    p.add_argument(
        "--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="params override, e.g. policies.targets=random (repeatable; with --init-from, applied to the source run's params)"
    )
    p.add_argument("--hp", dest="hps", action="append", default=[], metavar="KEY=VALUE", help="hyperparameter override, e.g. learning_rate=1e-4 (repeatable)")
    p.add_argument("--seed", type=int_at_least(0), default=0, help="seed of the training worlds and of torch (default 0)")
    p.add_argument("--out", required=True, help="run folder")
    p.add_argument("--init-from", default=None, metavar="DIR", help="start from this run's model (e.g. imitate.py's output)")
    p.add_argument("--num-envs", type=int_at_least(1), default=None, help="worlds in the VecEnv (default: sb3_hyperparams.yaml num_envs.<side>)")
    p.add_argument("--eval-freq", type=int_at_least(1), default=None, help="held-out evaluation every this many timesteps (default timesteps/10, and with --time-limit every tenth of it too)")
    p.add_argument("--eval-episodes", type=int_at_least(1), default=100, help="episodes per held-out evaluation (default 100)")
    p.add_argument("--checkpoint-freq", type=int_at_least(1), default=None, help="checkpoint every this many timesteps (default timesteps/5, and with --time-limit every fifth of it too)")
    p.add_argument("--threads", type=int_at_least(1), default=1, help="native worker threads for the VecEnv (default 1)")
    p.add_argument("--torch-threads", type=int_at_least(1), default=1, help="torch intra-op threads (default 1: small MLPs run fastest so)")
    p.add_argument("--time-limit", type=float, default=None, metavar="MINUTES", help="stop learning after this many minutes of wall time (the model is saved as usual)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def held_out_evaluation(model_side: str, params: dict, out: Path, args):
    """The held-out evaluation callback."""
    from stable_baselines3.common.callbacks import BaseCallback

    class HeldOutEvaluation(BaseCallback):
        """Every ``freq`` timesteps: the deterministic policy on episodes HELD_OUT_SEED + k
        against the scripted opponent; logs ``eval/*`` and keeps ``best_model.zip``."""

        def __init__(self, freq: int, episodes: int, period_s: float | None) -> None:
            super().__init__()
            self.freq, self.episodes, self.period_s = freq, episodes, period_s
            self.last = 0
            self.last_t = time.perf_counter()
            self.history: list[dict] = []
            self.best = -float("inf")
            self.seconds = 0.0

        def _on_training_start(self) -> None:
            self.t_start = time.perf_counter()
            self._evaluate()
            self.seconds_before_rollouts = self.seconds  # the others run inside rollout collection

        def _on_rollout_start(self) -> None:
            # Between rollouts the policy has just been updated: evaluating there (and only
            # there) never evaluates the same parameters twice, whatever --eval-freq says.
            if self.num_timesteps - self.last >= self.freq or clock_due(self.last_t, self.period_s):
                self._evaluate()

        def _on_step(self) -> bool:
            if deadline is not None and time.perf_counter() > deadline:
                return False  # --time-limit: SB3 ends learn() here
            return True

        def _evaluate(self) -> None:
            t0 = time.perf_counter()
            self.last = self.num_timesteps
            policy = lambda obs: self.model.predict(obs.reshape(-1, obs.shape[-1]), deterministic=True)[0].reshape(*obs.shape[:-1], 2).astype("float32")  # noqa: E731
            kw = {model_side: policy}
            row = report(
                rollout(params, episodes=self.episodes, seed=HELD_OUT_SEED, threads=args.threads, **kw),
                "learned" if model_side == "wolves" else params["policies"]["wolves"],
                "learned" if model_side == "targets" else params["policies"]["targets"],
            )
            row.pop("capture_steps")
            row["timesteps"] = self.num_timesteps
            row["train_s"] = t0 - self.t_start - self.seconds  # wall time of training so far, evaluations excluded
            ret = row["mean_return_wolves" if model_side == "wolves" else "mean_return_targets"]
            for key in ("capture_rate", "median_capture_steps", "collision_rate", "target_collision_rate", "timeout_rate"):
                if row[key] is not None:
                    self.logger.record(f"eval/{key}", row[key])
            self.logger.record("eval/mean_return", ret)
            if ret > self.best:
                self.best = ret
                self.model.save(out / "best_model.zip")
            self.history.append(row)
            (out / "evaluations.json").write_text(json.dumps(self.history, indent=1) + "\n")
            self.seconds += time.perf_counter() - t0
            self.last_t = time.perf_counter()

    deadline = None if args.time_limit is None else time.perf_counter() + 60 * args.time_limit
    return HeldOutEvaluation(args.eval_freq or max(1, args.timesteps // 10), args.eval_episodes, clock_period(args, args.eval_freq, 10))


def clock_period(args, freq: int | None, parts: int) -> float | None:
    """With --time-limit and no explicit frequency: seconds between evaluations (``parts`` = 10)
    or checkpoints (5), a ``parts``-th of the time limit — whichever budget ends the run, its
    cadence follows (a 4-minute run with the documented 30 M timesteps evaluated twice when only
    the timesteps set it)."""
    return 60 * args.time_limit / parts if args.time_limit is not None and freq is None else None


def clock_due(since: float, period_s: float | None) -> bool:
    return period_s is not None and time.perf_counter() - since >= period_s


def rollout_checkpoints(freq: int, folder: Path, period_s: float | None = None):
    """``checkpoints/model_<timesteps>_steps.zip`` at the first rollout boundary after every
    ``freq`` timesteps (or ``period_s`` seconds): between rollouts the policy has just changed, so no two checkpoints hold
    the same parameters (SB3's CheckpointCallback counts env steps and, with PPO's long
    rollouts, wrote the same model several times)."""
    from stable_baselines3.common.callbacks import BaseCallback

    class RolloutCheckpoints(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.last = 0
            self.last_t = time.perf_counter()

        def _on_rollout_start(self) -> None:
            if self.num_timesteps > self.last and (self.num_timesteps - self.last >= freq or clock_due(self.last_t, period_s)):
                self.last, self.last_t = self.num_timesteps, time.perf_counter()
                folder.mkdir(parents=True, exist_ok=True)
                self.model.save(folder / f"model_{self.num_timesteps}_steps.zip")

        def _on_step(self) -> bool:
            return True

    return RolloutCheckpoints()


def budget_bar(timesteps: int, time_limit_min: float):
    """A progress bar over the nearer of the two budgets (timesteps, minutes), updated at every
    rollout's end, with timesteps/s."""
    from stable_baselines3.common.callbacks import BaseCallback
    from tqdm import tqdm

    class BudgetBar(BaseCallback):
        def _on_training_start(self) -> None:
            self.t0 = time.perf_counter()
            self.bar = tqdm(total=1000, unit="‰", file=sys.stderr, bar_format="{percentage:3.0f}%|{bar:20}| {elapsed}<{remaining} {desc}")

        def _on_rollout_end(self) -> None:
            elapsed = time.perf_counter() - self.t0
            done = max(self.num_timesteps / timesteps, elapsed / (60 * time_limit_min))
            self.bar.update(min(1000, int(1000 * done)) - self.bar.n)
            self.bar.set_description_str(f"{self.num_timesteps:,} timesteps, {self.num_timesteps / max(elapsed, 1e-9):,.0f}/s", refresh=False)

        def _on_training_end(self) -> None:
            self.bar.close()

        def _on_step(self) -> bool:
            return True

    return BudgetBar()


def phase_timer():
    """A callback that splits learn() into rollout collection (env + policy inference + SB3
    bookkeeping) and the rest (gradient updates); ``.collect_s`` holds the first."""
    from stable_baselines3.common.callbacks import BaseCallback

    class PhaseTimer(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.collect_s = 0.0

        def _on_rollout_start(self) -> None:
            self._t0 = time.perf_counter()

        def _on_rollout_end(self) -> None:
            self.collect_s += time.perf_counter() - self._t0

        def _on_step(self) -> bool:
            return True

    return PhaseTimer()


def timed(env, stopwatch: Stopwatch):
    """``env`` with the time of every reset/step spent inside it added to ``stopwatch``."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class TimedVecEnv(VecEnvWrapper):
        def reset(self):
            with stopwatch:
                return self.venv.reset()

        def step_async(self, actions):
            with stopwatch:
                self.venv.step_async(actions)

        def step_wait(self):
            with stopwatch:
                return self.venv.step_wait()

    return TimedVecEnv(env)


def learning_curve(out: Path, history: list[dict], side: str) -> None:
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    t = [h["timesteps"] for h in history]
    rate = [100 * (h["capture_rate"] if side == "wolves" else h["survival_rate"]) for h in history]
    lo = [100 * (h["capture_rate_ci95"][0] if side == "wolves" else 1 - h["capture_rate_ci95"][1]) for h in history]
    hi = [100 * (h["capture_rate_ci95"][1] if side == "wolves" else 1 - h["capture_rate_ci95"][0]) for h in history]
    a.plot(t, rate, marker="o")
    a.fill_between(t, lo, hi, alpha=0.2)
    a.set_xlabel("timesteps")
    a.set_ylabel(("capture" if side == "wolves" else "survival") + " rate, held-out (%)")
    a.set_ylim(0, 100)
    a.grid(alpha=0.3)
    rows = list(csv.DictReader(open(out / "progress.csv"))) if (out / "progress.csv").exists() else []
    xs = [float(r["time/total_timesteps"]) for r in rows if r.get("rollout/ep_rew_mean")]
    ys = [float(r["rollout/ep_rew_mean"]) for r in rows if r.get("rollout/ep_rew_mean")]
    b.plot(xs, ys)
    b.set_xlabel("timesteps")
    b.set_ylabel("training episode return (per agent)")
    b.grid(alpha=0.3)
    fig.suptitle(f"{out.name}: {side} learning")
    fig.tight_layout()
    fig.savefig(out / "learning_curve.png", dpi=120)
    plt.close(fig)


def check_same_spaces(source, params: dict, side: str) -> None:
    """ValueError unless ``params`` gives the learning side the observation size and action
    mode that ``source`` was trained with (its weights would not fit, or would mean something
    else)."""
    ours = (observation_size(params, side), params["env"]["action_mode"])
    theirs = (int(source.model.observation_space.shape[0]), source.params["env"]["action_mode"])
    if theirs != ours:
        raise ValueError(f"--init-from {source.path.parent}: that model takes {theirs[0]} observations in {theirs[1]!r} action mode, these params give {ours[0]} in {ours[1]!r} mode")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        source = load_model(args.init_from) if args.init_from else None
        if source is not None and (source.side != args.side or source.algo != args.algo):
            raise ValueError(f"--init-from {args.init_from}: that model is {source.algo} for {source.side}, this run is {args.algo} for {args.side}")
        # Fine-tuning continues on the source run's scenario (action mode, counts, opponent...):
        # a policy cloned in velocity mode means nothing in unicycle mode. --params replaces
        # that scenario, --set changes it.
        base = source.config["params"] if source is not None and args.params is None else args.params
        params = env_params(base, args.sets)
        if source is not None:
            check_same_spaces(source, params, args.side)
        hp = hyperparams(args.algo, source is not None, args.hps)
        if source is not None:
            # The architecture must be the source's, or its weights do not fit.
            hp["policy_kwargs"] = source.config["hyperparams"].get("policy_kwargs", {})
        table = yaml.safe_load(HYPERPARAMS_PATH.read_text())  # num_envs.<side>
        num_envs = args.num_envs or int(table["num_envs"][args.side])
        out = prepare_out(args.out)
    except ValueError as e:
        print(f"train.py: error: {e}", file=sys.stderr)
        return 2

    import torch
    import wolfpack
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import VecMonitor

    torch.set_num_threads(args.torch_threads)
    set_random_seed(args.seed)
    train_seed = TRAIN_SEED_BASE * (args.seed + 1)
    config = {
        "side": args.side,
        "algo": args.algo,
        "timesteps": args.timesteps,
        "seed": args.seed,
        "num_envs": num_envs,
        "train_world_seeds": f"{train_seed} + e",
        "held_out_seeds": f"{HELD_OUT_SEED} + k ({args.eval_episodes} episodes)",
        "init_from": str(Path(args.init_from).resolve()) if args.init_from else None,
        "threads": args.threads,
        "torch_threads": args.torch_threads,
        "command": " ".join(shlex.quote(a) for a in ["python", "training/train.py", *(sys.argv[1:] if argv is None else argv)]),
        "versions": versions(),
        "hyperparams": hp,
        "params": params,
    }
    write_config(out, config)

    env_time = Stopwatch()
    env = VecMonitor(timed(wolfpack.make_vec_env(params, num_envs=num_envs, learners=args.side, seed=train_seed, threads=args.threads), env_time))
    algo = algorithms()[args.algo]
    model = algo("MlpPolicy", env, seed=args.seed, device="cpu", verbose=0, **sb3_kwargs(hp))
    if source is not None:
        model.policy.load_state_dict(source.model.policy.state_dict())
    model.set_logger(configure(str(out), ["csv", "tensorboard", "log"]))
    evaluation = held_out_evaluation(args.side, params, out, args)
    ckpt_freq = args.checkpoint_freq or max(1, args.timesteps // 5)
    phases = phase_timer()
    callbacks = [phases, evaluation, rollout_checkpoints(ckpt_freq, out / "checkpoints", clock_period(args, args.checkpoint_freq, 5))]
    # SB3's bar counts timesteps: with a time limit that ends the run first it promised hours.
    # Then the bar follows whichever budget is nearer its end.
    timed_bar = args.time_limit is not None and not args.no_progress
    if timed_bar:
        callbacks.append(budget_bar(args.timesteps, args.time_limit))

    t0 = time.perf_counter()
    model.learn(total_timesteps=args.timesteps, callback=callbacks, progress_bar=not args.no_progress and not timed_bar)
    wall = time.perf_counter() - t0
    eval_in_learn = evaluation.seconds  # held-out evaluations during learn(), not training
    model.save(out / MODEL_FILE)
    evaluation._evaluate()  # the final model on the held-out episodes
    learning_curve(out, evaluation.history, args.side)

    train_wall = wall - eval_in_learn
    collect = phases.collect_s - (eval_in_learn - evaluation.seconds_before_rollouts)
    summary = {
        "timesteps": int(model.num_timesteps),
        "stopped_by_time_limit": int(model.num_timesteps) < args.timesteps,
        "world_steps": int(model.num_timesteps) // (env.num_envs // num_envs),
        "wall_s": wall,
        "held_out_eval_s": eval_in_learn,
        "training_s": train_wall,
        "env_s": env_time.total,
        "env_share_of_training": env_time.total / train_wall if train_wall > 0 else None,
        "collect_s": collect,  # rollout collection: env + policy inference + SB3 bookkeeping
        "update_s": train_wall - collect,  # gradient updates
        "timesteps_per_s": model.num_timesteps / train_wall if train_wall > 0 else None,
        "final_held_out": evaluation.history[-1],
        "best_held_out_mean_return": evaluation.best,
    }
    (out / "train_summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    final = evaluation.history[-1]
    print(
        f"{args.side} {args.algo}: {summary['timesteps']} timesteps in {wall:.0f} s "
        f"(env {100 * (summary['env_share_of_training'] or 0):.0f} % of training time); held-out capture rate "
        f"{100 * final['capture_rate']:.1f} % [{100 * final['capture_rate_ci95'][0]:.1f}, {100 * final['capture_rate_ci95'][1]:.1f}], "
        f"median capture steps {final['median_capture_steps']}; model: {out / MODEL_FILE}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
