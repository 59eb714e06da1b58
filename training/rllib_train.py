"""Train wolves, targets or both with RLlib's PPO (new API stack), on one machine or a Ray cluster.

    python training/rllib_train.py --iterations 2 --num-env-runners 2 --out runs/rllib
    python training/rllib_train.py --policies shared --time-limit 30 --out runs/rllib_shared
    python training/rllib_train.py --address auto --num-env-runners 16 --out runs/rllib_cluster

The environment is ``wolfpack.parallel_env`` wrapped in RLlib's own ``ParallelPettingZooEnv``
(``wolfpack.rllib.env_creator``; env runner k's worlds are seeded from ``--seed`` and k). ``--learners both`` (default) trains both sides at once; the
other choices train one side against the other side's scripted law (``policies.*`` in the
params). ``--policies sides`` (default) gives each learning side its own RLModule (``wolves``,
``targets``), parameter-shared among that side's agents; ``--policies shared`` one RLModule for
every agent, on the shared observation space (``shared_space=True``: side flag, agent one-hot,
padded observation; needs ``--learners both``).

Scaling: ``--num-env-runners K`` samples on K Ray actors (one CPU each), ``--envs-per-runner``
worlds each; the learner (PPO's update) runs in this process. ``--address auto`` joins a running
Ray cluster (``ray start --head`` on one machine, ``ray start --address HEAD:6379`` on the
others; every machine needs this project installed in the same environment), otherwise a local
Ray instance with ``--num-cpus`` CPUs is started.

Writes, under ``--out`` (which must be new or empty, unless ``--resume``): ``config.yaml`` (the
arguments and the resolved params), ``progress.csv`` (one row per iteration: env steps, time,
episodes, env-steps/s over the iteration, seconds spent sampling and in PPO's update, episode
return per module, empty in an iteration where no episode ended), ``checkpoint/`` (RLlib's checkpoint, every
``--checkpoint-every`` iterations and at the end, also on Ctrl-C) and ``summary.json`` (written
last). ``--resume DIR`` continues a run from its checkpoint.

Not here: a MAPPO-style centralised critic on ``env.state()``. RLlib's new API stack ships no
centralised-critic example (only ``rllib/examples/_old_api_stack/centralized_critic.py``);
one needs a custom MultiRLModule with a shared value head plus a learner connector that adds
the global state to each agent's batch. ``wolfpack.parallel_env(...).state()`` provides the
input.
"""

from __future__ import annotations

import argparse
import csv
import json
import signal
import sys
import time
from pathlib import Path

import wolfpack
from wolfpack.cli.args import int_at_least, positive_number
from wolfpack.learn.sb3 import env_params
from wolfpack.rllib import env_creator, shared_mapping, side_mapping

ENV_NAME = "wolfpack_parallel"
LEARNERS = ("both", "wolves", "targets")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rllib_train.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--learners", choices=LEARNERS, default="both", help="who learns (default both: wolves and targets at once)")
    p.add_argument("--policies", choices=("sides", "shared"), default="sides", help="one RLModule per side (default) or one shared by every agent")
    p.add_argument("--iterations", type=int_at_least(1), default=None, help="PPO iterations (default: until --time-limit, else 100)")
    p.add_argument("--time-limit", type=positive_number, default=None, metavar="MIN", help="stop after this many minutes (checked after each iteration)")
    p.add_argument("--num-env-runners", type=int, default=2, help="sampling actors (0: sample in this process; default 2)")
    p.add_argument("--envs-per-runner", type=int_at_least(1), default=1, help="worlds per env runner (default 1)")
    p.add_argument("--address", default=None, help="Ray cluster to join ('auto': the one on this machine); default: start a local Ray")
    p.add_argument("--num-cpus", type=int_at_least(1), default=None, help="CPUs of the local Ray instance (default: all cores)")
    p.add_argument("--train-batch", type=int_at_least(1), default=4000, help="env steps per PPO update (default 4000)")
    p.add_argument("--minibatch", type=int_at_least(1), default=500, help="PPO minibatch (default 500)")
    p.add_argument("--epochs", type=int_at_least(1), default=5, help="PPO epochs per update (default 5)")
    p.add_argument("--lr", type=positive_number, default=3e-4, help="learning rate (default 3e-4)")
    p.add_argument("--seed", type=int_at_least(0), default=0, help="run seed: env runner k's world is seeded from it (default 0)")
    p.add_argument("--params", default=None, help="params YAML (default: the documented scenario)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="params override (repeatable)")
    p.add_argument("--checkpoint-every", type=int_at_least(1), default=10, metavar="K", help="checkpoint every K iterations (and at the end)")
    p.add_argument("--out", default="runs/rllib", help="run folder (default runs/rllib; must be new or empty)")
    p.add_argument("--resume", default=None, metavar="DIR", help="continue the run in DIR from its checkpoint (writes into DIR)")
    return p


def module_ids(args) -> list[str]:
    """The RLModules trained: ``shared``, or one per learning side."""
    if args.policies == "shared":
        return ["shared"]
    return {"both": ["wolves", "targets"], "wolves": ["wolves"], "targets": ["targets"]}[args.learners]


def algorithm_config(args, params: dict):
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    modules = module_ids(args)
    env_config = {"params": params, "learners": args.learners, "shared_space": args.policies == "shared", "seed": args.seed}
    return (
        PPOConfig()
        .environment(ENV_NAME, env_config=env_config)
        .env_runners(num_env_runners=args.num_env_runners, num_envs_per_env_runner=args.envs_per_runner)
        .multi_agent(policies=set(modules), policy_mapping_fn=shared_mapping if args.policies == "shared" else side_mapping)
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={m: RLModuleSpec() for m in modules}))
        .training(train_batch_size_per_learner=args.train_batch, minibatch_size=args.minibatch, num_epochs=args.epochs, lr=args.lr)
        .debugging(seed=args.seed)
    )


def check_args(args) -> Path:
    if args.num_env_runners < 0:
        raise ValueError(f"--num-env-runners must be >= 0, got {args.num_env_runners}")
    if args.policies == "shared" and args.learners != "both":
        raise ValueError("--policies shared needs --learners both (one module for both sides)")
    if args.minibatch > args.train_batch:
        raise ValueError(f"--minibatch {args.minibatch} exceeds --train-batch {args.train_batch}")
    if args.resume is not None:
        out = Path(args.resume)
        if not (out / "checkpoint").is_dir() or not (out / "config.yaml").is_file():
            raise ValueError(f"--resume {out}: no checkpoint/ and config.yaml there")
        return out
    out = Path(args.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ValueError(f"--out {out}: exists and is not an empty folder (choose a new one, or --resume it)")
    return out


def reachable(address: str, timeout_s: float = 5.0) -> None:
    """A HOST:PORT cluster address must answer a TCP connection within ``timeout_s``: Ray's own
    client retries an absent head for minutes before it gives up. (``auto`` and ``ray://``
    addresses are left to Ray, which fails fast on them.)"""
    import socket

    if address == "auto" or "://" in address:
        return
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit():
        raise ValueError(f"expected HOST:PORT, 'auto' or ray://HOST:PORT, got {address!r}")
    try:
        socket.create_connection((host, int(port)), timeout=timeout_s).close()
    except OSError as e:
        raise ConnectionError(f"no Ray head answers at {address} ({e.strerror or e})") from None


def returns_of(result: dict, modules: list[str]) -> dict[str, str | float]:
    """Mean episode return per module, as progress.csv columns ``return_<module>``.

    Every module always has its column: an iteration in which no episode ended (short
    iterations, loaded machines) writes it empty instead of leaving the column out, which
    would fix the CSV header without it and silently drop every later iteration's returns."""
    per_module = result.get("env_runners", {}).get("module_episode_returns_mean", {}) or {}
    return {f"return_{m}": round(float(per_module[m]), 4) if m in per_module else "" for m in modules}


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        out = check_args(args)
        if args.resume is not None:
            import yaml

            saved = yaml.safe_load((out / "config.yaml").read_text())
            params = saved["params"]
            for key in ("learners", "policies"):
                setattr(args, key, saved["args"][key])
        else:
            params = env_params(args.params, args.sets)
            if args.policies == "shared":
                wolfpack.parallel_env(params, learners="both", shared_space=True)  # fails here, not in an actor
    except ValueError as e:
        print(f"rllib_train.py: error: {e}", file=sys.stderr)
        return 2
    iterations = args.iterations or (None if args.time_limit else 100)

    import ray
    import yaml
    from ray.tune.registry import register_env
    from tqdm import tqdm

    try:
        if args.address is not None:
            reachable(args.address)
            ray.init(address=args.address, log_to_driver=False)
        else:
            ray.init(num_cpus=args.num_cpus, include_dashboard=False, log_to_driver=False)
    except (ConnectionError, RuntimeError, ValueError) as e:
        print(f"rllib_train.py: error: --address {args.address}: cannot start or join Ray ({str(e).splitlines()[0]})", file=sys.stderr)
        return 2
    register_env(ENV_NAME, env_creator)
    algo = algorithm_config(args, params).build_algo()
    if args.resume is not None:
        algo.restore_from_path(str((out / "checkpoint").resolve()))
    else:  # only now: a run that could not start leaves no folder behind
        out.mkdir(parents=True, exist_ok=True)
        (out / "config.yaml").write_text(yaml.safe_dump({"args": vars(args), "params": params}, sort_keys=False))
    progress_path = out / "progress.csv"
    new_file = not progress_path.exists()
    stop = {"now": False}

    def on_interrupt(*_):
        # First Ctrl-C: finish this iteration, checkpoint, summarise. Second: abort at once.
        if stop["now"]:
            raise KeyboardInterrupt
        stop["now"] = True
        print("rllib_train.py: stopping after this iteration (Ctrl-C again to abort without a checkpoint)", file=sys.stderr, flush=True)

    previous = signal.signal(signal.SIGINT, on_interrupt)
    t0 = time.perf_counter()
    done = 0
    last: dict = {}
    try:
        with open(progress_path, "a", newline="") as f, tqdm(total=iterations, unit="it", desc="rllib ppo", disable=not sys.stderr.isatty()) as bar:
            writer = None
            while not stop["now"] and (iterations is None or done < iterations):
                t_iter = time.perf_counter()
                result = algo.train()
                done += 1
                runners = result.get("env_runners", {})
                row = {
                    "iteration": int(result.get("training_iteration", done)),
                    "env_steps": int(result.get("num_env_steps_sampled_lifetime", runners.get("num_env_steps_sampled_lifetime", 0))),
                    "time_s": round(time.perf_counter() - t0, 2),
                    "episodes": int(runners.get("num_episodes_lifetime", 0)),
                    "env_steps_per_s": round(float(runners.get("num_env_steps_sampled", 0)) / max(time.perf_counter() - t_iter, 1e-9), 1),
                    # where an iteration's time goes: sampling on the env runners vs PPO's update
                    "sample_s": round(float(result.get("timers", {}).get("env_runner_sampling_timer", float("nan"))), 3),
                    "learn_s": round(float(result.get("timers", {}).get("learner_update_timer", float("nan"))), 3),
                    **returns_of(result, module_ids(args)),
                }
                if writer is None:
                    writer = csv.DictWriter(f, fieldnames=list(row), extrasaction="ignore")
                    if new_file:
                        writer.writeheader()
                writer.writerow(row)
                f.flush()
                last = row
                bar.update(1)
                bar.set_postfix({k: v for k, v in row.items() if k.startswith("return_") and v != ""})
                if not sys.stderr.isatty():
                    print(json.dumps(row), flush=True)
                if done % args.checkpoint_every == 0:
                    algo.save_to_path(str((out / "checkpoint").resolve()))
                if args.time_limit is not None and time.perf_counter() - t0 >= 60 * args.time_limit:
                    break
        algo.save_to_path(str((out / "checkpoint").resolve()))
        summary = {
            "iterations_this_run": done,
            "last": last,
            "wall_time_s": round(time.perf_counter() - t0, 2),
            "interrupted": stop["now"],
            "num_env_runners": args.num_env_runners,
            "ray_address": args.address or "local",
        }
        tmp = out / ".summary.json.tmp"
        tmp.write_text(json.dumps(summary, indent=1) + "\n")
        tmp.replace(out / "summary.json")
    except KeyboardInterrupt:
        print(f"rllib_train.py: aborted; {out}/checkpoint holds the last checkpoint (if any) and progress.csv every finished iteration", file=sys.stderr)
        return 130
    finally:
        signal.signal(signal.SIGINT, previous)
        algo.stop()
        ray.shutdown()
    print(f"wrote {out}/progress.csv, checkpoint/ and summary.json ({done} iterations, {last.get('env_steps', 0)} env steps)")
    return 130 if stop["now"] else 0


if __name__ == "__main__":
    sys.exit(main())
