"""Imitate an analytic law: behaviour cloning with DAgger, into an SB3 policy.

    python training/imitate.py --side wolves --out runs/wolves_bc
    python training/train.py --side wolves --timesteps 3000000 --out runs/wolves_ft --init-from runs/wolves_bc

The expert is the scripted law of the learning side (params ``policies.wolves`` or
``policies.targets``), queried through ``BatchEnv.expert_actions()``: the action the law would
take in the current state, in the learner's action space. Round 0 drives the worlds with the
expert itself; round r ≥ 1 drives them with the expert with probability β_r = beta·decay^(r−1)
per agent and step, and with the current policy otherwise (DAgger: the policy learns what the
expert would do in the states the policy itself reaches). Every round the expert's labels are
added to the data set and the policy's mean action is fitted to them (mean squared error) for
--epochs passes.

The result is an SB3 model (PPO by default, the Gaussian mean is the cloned action; with
--algo sac the actor's squashed mean) that ``train.py --init-from`` fine-tunes: for PPO the
policy's log standard deviation is set to --log-std (exploration for the fine-tuning) and the
value head is fitted to discounted Monte-Carlo returns of the cloned policy's own episodes, so
the first PPO updates see a sensible critic instead of a random one.

The model kept is the policy of the best round on held-out episodes (500000 + k; capture rate
for wolves, survival rate for targets), as DAgger prescribes; these seeds are disjoint from
evaluate.py's.

Writes into --out: model.zip, config.yaml (as train.py's), imitation.json (``best_round`` and
per round: β, data set size, loss, the held-out evaluation of the deterministic policy),
imitation.png.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
import warnings

import numpy as np
from wolfpack.cli.args import int_at_least
from wolfpack.evaluation import HELD_OUT_SEED, IMITATION_SEED_BASE, report, rollout
from wolfpack.learn.sb3 import SB3_ALGOS, algorithms, env_params, hyperparams, prepare_out, sb3_kwargs, versions, write_config
from wolfpack.models import MODEL_FILE
from wolfpack.report.imitation import plot
from wolfpack.sides import SIDES


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="imitate.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--side", required=True, choices=SIDES, help="whose law to imitate")
    p.add_argument("--out", required=True, help="run folder")
    p.add_argument("--algo", default="ppo", choices=SB3_ALGOS, help="SB3 policy type to produce (default ppo)")
    p.add_argument("--params", default=None, help="params YAML (default: the documented scenario)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="params override (repeatable)")
    p.add_argument("--hp", dest="hps", action="append", default=[], metavar="KEY=VALUE", help="hyperparameter override of the produced model, e.g. policy_kwargs.net_arch.pi=[128,128]")
    p.add_argument("--seed", type=int_at_least(0), default=0, help="seed (default 0)")
    p.add_argument("--num-envs", type=int_at_least(1), default=32, help="worlds collecting data (default 32)")
    p.add_argument("--rounds", type=int_at_least(1), default=12, help="DAgger rounds, the first one pure expert (default 12)")
    p.add_argument("--steps-per-round", type=int_at_least(1), default=600, help="world steps collected per round (default 600 = two episode lengths)")
    p.add_argument("--epochs", type=int_at_least(1), default=8, help="passes over the aggregated data set per round (default 8)")
    p.add_argument("--batch-size", type=int_at_least(1), default=1024, help="minibatch size (default 1024)")
    p.add_argument("--lr", type=float, default=5e-4, help="Adam learning rate (default 5e-4)")
    p.add_argument("--beta", type=float, default=0.5, help="β of round 1 (default 0.5)")
    p.add_argument("--decay", type=float, default=0.5, help="β_r = beta·decay^(r−1) (default 0.5)")
    p.add_argument("--log-std", type=float, default=-1.2, help="PPO: log std of the produced policy (default -1.2, std 0.3)")
    p.add_argument("--eval-episodes", type=int_at_least(1), default=100, help="held-out episodes evaluated after each round (default 100)")
    p.add_argument("--threads", type=int_at_least(1), default=1, help="native worker threads (default 1)")
    p.add_argument("--torch-threads", type=int_at_least(1), default=1, help="torch threads (default 1)")
    return p


def mean_action(policy, obs_t, algo: str):
    """The deterministic action of an SB3 policy as a differentiable tensor."""
    if algo == "ppo":
        return policy.get_distribution(obs_t).distribution.mean
    mean, _, _ = policy.actor.get_action_dist_params(obs_t)
    return mean.tanh()


def discounted_returns(rewards: np.ndarray, ends: np.ndarray, gamma: float) -> np.ndarray:
    """Returns-to-go G_t = r_t + γ G_{t+1} along axis 0, restarting after every episode end
    (``ends[t]`` True: the episode ended at step t); the window's last step bootstraps with 0."""
    out = np.zeros_like(rewards, dtype=np.float64)
    g = np.zeros(rewards.shape[1:], dtype=np.float64)
    for t in range(len(rewards) - 1, -1, -1):
        g = rewards[t] + gamma * np.where(ends[t], 0.0, g)
        out[t] = g
    return out


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        params = env_params(args.params, args.sets)
        hp = hyperparams(args.algo, False, args.hps)
        out = prepare_out(args.out)
        if not 0.0 <= args.beta <= 1.0 or not 0.0 <= args.decay <= 1.0:
            raise ValueError(f"--beta and --decay must lie in [0, 1], got {args.beta} and {args.decay}")
    except ValueError as e:
        print(f"imitate.py: error: {e}", file=sys.stderr)
        return 2

    import torch
    import wolfpack
    from stable_baselines3.common.utils import set_random_seed
    from tqdm import tqdm

    torch.set_num_threads(args.torch_threads)
    set_random_seed(args.seed)
    rng = np.random.default_rng(args.seed)
    side = args.side
    world_seed = IMITATION_SEED_BASE * (args.seed + 1)
    config = {
        "side": side,
        "algo": args.algo,
        "imitation_of": params["policies"][side],
        "seed": args.seed,
        "num_envs": args.num_envs,
        "imitation_world_seeds": f"{world_seed} + e",
        "held_out_seeds": f"{HELD_OUT_SEED} + k ({args.eval_episodes} episodes)",
        "imitation": {k: getattr(args, k) for k in ("rounds", "steps_per_round", "epochs", "batch_size", "lr", "beta", "decay", "log_std")},
        "command": " ".join(shlex.quote(a) for a in ["python", "training/imitate.py", *(sys.argv[1:] if argv is None else argv)]),
        "versions": versions(),
        "hyperparams": hp,
        "params": params,
    }
    write_config(out, config)

    vec = wolfpack.make_vec_env(params, num_envs=1, learners=side, seed=world_seed)  # gives the model its spaces
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # PPO's batch-size advice for this 1-world env; train.py builds its own
        model = algorithms()[args.algo]("MlpPolicy", vec, seed=args.seed, device="cpu", **sb3_kwargs(hp))
    policy = model.policy
    params_to_fit = list(policy.actor.parameters()) if args.algo == "sac" else [p for n, p in policy.named_parameters() if not n.startswith(("value_net", "mlp_extractor.value_net", "log_std"))]
    optimiser = torch.optim.Adam(params_to_fit, lr=args.lr)
    batch = wolfpack.BatchEnv(params, num_envs=args.num_envs, learners=side, seed=world_seed, autoreset=True, threads=args.threads)
    obs_key = f"obs_{side}"

    def act(obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            a = mean_action(policy, torch.as_tensor(obs.reshape(-1, obs.shape[-1])), args.algo).numpy()
        return np.clip(a, -1, 1).astype(np.float32).reshape(*obs.shape[:-1], 2)

    def held_out() -> dict:
        kw = {side: act}
        row = report(
            rollout(params, episodes=args.eval_episodes, seed=HELD_OUT_SEED, threads=args.threads, **kw),
            "cloned" if side == "wolves" else params["policies"]["wolves"],
            "cloned" if side == "targets" else params["policies"]["targets"],
        )
        row.pop("capture_steps")
        return row

    import copy

    def score(row: dict) -> float:  # what "best round" means: the learner side's success
        return row["capture_rate"] if side == "wolves" else 1.0 - row["capture_rate"]

    best_state, best_score, best_round = None, -1.0, -1
    data_obs: list[np.ndarray] = []
    data_act: list[np.ndarray] = []
    history = []
    out_state = batch.reset(world_seed)
    t0 = time.perf_counter()
    for r in tqdm(range(args.rounds), desc="DAgger rounds", unit="round", disable=not sys.stderr.isatty()):
        beta = 1.0 if r == 0 else args.beta * args.decay ** (r - 1)
        for _ in range(args.steps_per_round):
            obs = out_state[obs_key]
            wolf_expert, target_expert = batch.expert_actions()
            expert = wolf_expert if side == "wolves" else target_expert
            data_obs.append(obs.reshape(-1, obs.shape[-1]).copy())
            data_act.append(expert.reshape(-1, 2).copy())
            if beta >= 1.0:
                executed = expert
            else:
                mine = act(obs)
                use_expert = rng.random(expert.shape[:-1]) < beta
                executed = np.where(use_expert[..., None], expert, mine).astype(np.float32)
            out_state = batch.step(executed, None) if side == "wolves" else batch.step(None, executed)
        X = torch.as_tensor(np.concatenate(data_obs))
        Y = torch.as_tensor(np.concatenate(data_act))
        losses = []
        for _ in range(args.epochs):
            perm = torch.randperm(len(X))
            for i in range(0, len(X), args.batch_size):
                idx = perm[i : i + args.batch_size]
                loss = torch.nn.functional.mse_loss(mean_action(policy, X[idx], args.algo), Y[idx])
                optimiser.zero_grad()
                loss.backward()
                optimiser.step()
                losses.append(loss.item())
        row = held_out()
        entry = {"round": r, "beta": beta, "samples": int(len(X)), "loss": float(np.mean(losses[-max(1, len(losses) // args.epochs) :])), "held_out": row, "elapsed_s": time.perf_counter() - t0}
        history.append(entry)
        if score(row) > best_score:
            best_state, best_score, best_round = copy.deepcopy(policy.state_dict()), score(row), r
        print(
            f"round {r}: beta {beta:.3f}, {len(X)} samples, loss {entry['loss']:.4f}, held-out capture rate {100 * row['capture_rate']:.1f} %, median steps {row['median_capture_steps']}", flush=True
        )
        (out / "imitation.json").write_text(json.dumps({"best_round": best_round, "rounds": history}, indent=1) + "\n")

    # DAgger returns the best policy of its rounds on held-out episodes (Ross et al., 2011);
    # the held-out seeds are disjoint from evaluate.py's, so reports carry no selection bias.
    policy.load_state_dict(best_state)
    (out / "imitation.json").write_text(json.dumps({"best_round": best_round, "rounds": history}, indent=1) + "\n")
    if args.algo == "ppo":
        fit_value(policy, batch, side, act, hp.get("gamma", 0.99), params["world"]["max_steps"], args)
        with torch.no_grad():
            policy.log_std.fill_(args.log_std)
    model.save(out / MODEL_FILE)
    plot(out, history, side)
    final = history[best_round]["held_out"]
    print(
        f"best round {best_round}: imitation of {params['policies'][side]} ({side}): held-out capture rate {100 * final['capture_rate']:.1f} % "
        f"[{100 * final['capture_rate_ci95'][0]:.1f}, {100 * final['capture_rate_ci95'][1]:.1f}], median capture steps {final['median_capture_steps']}; "
        f"{time.perf_counter() - t0:.0f} s; model: {out / MODEL_FILE}"
    )
    return 0


def fit_value(policy, batch, side: str, act, gamma: float, max_steps: int, args) -> None:
    """Fits the PPO value head to discounted returns of the cloned policy's own episodes: two
    episode lengths of rollout, targets from the first one (whose returns are nearly complete)."""
    import torch

    obs_key, rew_key = f"obs_{side}", f"rewards_{side}"
    out = batch.reset(IMITATION_SEED_BASE * (args.seed + 1) + 10_000)
    obs_list, rew_list, end_list = [], [], []
    for _ in range(2 * max_steps):
        obs = out[obs_key]
        obs_list.append(obs.reshape(-1, obs.shape[-1]).copy())
        a = act(obs)
        out = batch.step(a, None) if side == "wolves" else batch.step(None, a)
        per_world = obs.shape[1]
        rew_list.append(out[rew_key].reshape(-1))
        end_list.append(np.repeat(out["terminated"] | out["truncated"], per_world))
    returns = discounted_returns(np.array(rew_list), np.array(end_list), gamma)[:max_steps].reshape(-1)
    X = torch.as_tensor(np.concatenate(obs_list[:max_steps]))
    Y = torch.as_tensor(returns, dtype=torch.float32)
    value_params = [p for n, p in policy.named_parameters() if n.startswith(("value_net", "mlp_extractor.value_net"))]
    opt = torch.optim.Adam(value_params, lr=1e-3)
    for _ in range(10):
        perm = torch.randperm(len(X))
        for i in range(0, len(X), args.batch_size):
            idx = perm[i : i + args.batch_size]
            loss = torch.nn.functional.mse_loss(policy.predict_values(X[idx]).squeeze(-1), Y[idx])
            opt.zero_grad()
            loss.backward()
            opt.step()


if __name__ == "__main__":
    sys.exit(main())
