"""Offline datasets of expert play: ``wolfpack dataset`` (docs/tasks.md, "Datasets").

A policy — a law or a saved model — plays one side of a task while the other side follows the
task's scripted law, over episodes ``seed .. seed + episodes − 1`` (the episodes of ``wolfpack
hunt --seed S``). Every recorded action is the one that moved its agent: a law's side acts
through ``expert_actions()`` (its command as an action: the episodes are ``wolfpack hunt``'s up
to the encoding's rounding — on seeds 0–999 of hunt-v1 the same outcomes, 7 ending at another
step).

Two formats:

- **Minari** (Farama's offline-RL standard; the ``[dataset]`` extra, Python ≥ 3.11) for the
  single-learner view — a target policy on a task with one target, i.e. what
  ``gymnasium.make("wolfpack/Escape-<task>")`` sees: per episode ``observations`` [L+1, D]
  (the last is the final observation), ``actions`` [L, 2], ``rewards``, ``terminations``,
  ``truncations``; the wolves run inside the core exactly as in that env. The dataset id is ``wolfpack/<task>/<policy>-v0`` and it is written under
  ``DIR`` (Minari's ``MINARI_DATASETS_PATH``); ``minari.load_dataset(id)`` with that path set
  reads it back, and ``dataset.recover_environment()`` builds the env.
- **npz** (the project's own) for everything else — wolves, several targets: the whole
  multi-agent trajectories (both sides through the action interface, both recorded) in ``DIR/trajectories.npz``, episodes concatenated along the first
  axis (:data:`NPZ_KEYS`), with ``DIR/dataset.json`` saying what it holds; :func:`load_npz`
  reads it back and :func:`episodes` splits it.
"""

from __future__ import annotations

import json
import os
import re
import time
import warnings
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from wolfpack._optional import require
from wolfpack.batch import OUTCOMES, BatchEnv
from wolfpack.opponents import Opponent
from wolfpack.outputs import Outputs
from wolfpack.sides import SIDES, bring_observation, mode_key
from wolfpack.task import check_task, gym_id, single_target_tasks, task_params

#: The arrays of ``trajectories.npz``: per step (T = all episodes' steps), per episode (K), or
#: the K + 1 offsets of the episodes in the step arrays.
NPZ_KEYS = {
    "obs_wolves": "[T, N, Dw] float32: each wolf's observation before the step",
    "obs_targets": "[T, M, Dt] float32: each target's observation before the step",
    "state": "[T, S] float32: the world's global state before the step (BatchEnv.state())",
    "actions_wolves": "[T, N, 2] float32: the wolves' actions",
    "actions_targets": "[T, M, 2] float32: the targets' actions",
    "rewards_wolves": "[T, N] float32",
    "rewards_targets": "[T, M] float32",
    "terminated": "[T] bool: the episode ended at this step (captured, collision, cornered)",
    "truncated": "[T] bool: the episode hit world.max_steps at this step",
    "final_obs_wolves": "[K, N, Dw] float32: the wolves' observations after each episode's last step",
    "final_obs_targets": "[K, M, Dt] float32",
    "episode_offsets": "[K + 1] int64: episode k is rows offsets[k] .. offsets[k+1] − 1",
    "seeds": "[K] uint64: episode k is world seed + k's first episode",
    "outcome": "[K] uint8: the outcome code (wolfpack.OUTCOMES)",
}
#: Worlds stepped together while collecting.
CHUNK = 256


def _driver(policy: Any, side: str) -> Opponent:
    if side not in SIDES:
        raise ValueError(f"side must be 'wolves' or 'targets', got {side!r}")
    return policy if isinstance(policy, Opponent) else Opponent(policy, side=side, deterministic=True, role="policy")


def policy_side(policy: Any) -> str:
    """The side a law or a saved model plays (ValueError when it cannot say: a callable)."""
    driver = Opponent(policy, role="policy") if not isinstance(policy, Opponent) else policy
    if driver.side is None:
        raise ValueError(f"{driver.name!r}: say which side it plays (side='wolves' or 'targets')")
    return driver.side


def params_for(task: str, driver: Opponent, side: str) -> dict:
    """Task ``task``'s params with ``driver`` on ``side``: a law becomes that side's scripted
    law (its expert actions are then the law's); a model brings its observation keys and action
    mode, so that it sees what it was trained on."""
    params = task_params(check_task(task))
    if driver.kind == "scripted":
        params["policies"][side] = driver.law
    else:
        bring_observation(params, driver.observation)
        if driver.action_mode is not None:
            params["env"][mode_key(side)] = driver.action_mode
    return params


def collect(
    task: str, policy: Any, side: str, *, episodes: int, seed: int = 0, threads: int | None = None, both_sides: bool = True, progress: Callable[[int], None] | None = None
) -> dict[str, np.ndarray]:
    """Plays ``episodes`` episodes of ``task`` with ``policy`` on ``side`` and returns the
    arrays of :data:`NPZ_KEYS`. ``both_sides``: the other side acts through the action
    interface too (its law's expert actions), so that its observations and actions are
    recorded; otherwise it runs inside the core exactly as in the single-learner envs (the
    Gymnasium view; its observations and actions are then not in the arrays)."""
    driver = _driver(policy, side)
    params = params_for(task, driver, side)
    per_episode: list[dict[str, np.ndarray]] = []
    for first in range(0, episodes, CHUNK):
        count = min(CHUNK, episodes - first)
        per_episode += _collect_chunk(params, driver, side, count, seed + first, threads, "both" if both_sides else side)
        if progress is not None:
            progress(count)
    steps = [len(ep["terminated"]) for ep in per_episode]
    out = {key: np.concatenate([ep[key] for ep in per_episode]) for key in per_episode[0] if key not in ("outcome",) and not key.startswith("final_")}
    for key in [k for k in per_episode[0] if k.startswith("final_")]:
        out[key] = np.stack([ep[key] for ep in per_episode])
    out["episode_offsets"] = np.concatenate([[0], np.cumsum(steps)]).astype(np.int64)
    out["seeds"] = np.arange(seed, seed + episodes, dtype=np.uint64)
    out["outcome"] = np.array([ep["outcome"] for ep in per_episode], np.uint8)
    return out


def _collect_chunk(params: dict, driver: Opponent, side: str, count: int, seed: int, threads: int | None, learners: str) -> list[dict]:
    batch = BatchEnv(params, num_envs=count, learners=learners, seed=seed, autoreset=False, threads=threads)
    sides = SIDES if learners == "both" else (side,)
    if driver.obs_dim is not None:
        here = batch.wolf_obs_dim if side == "wolves" else batch.target_obs_dim
        if driver.obs_dim != here:
            raise ValueError(f"{driver.name!r} takes {driver.obs_dim} observations, but the {side} of this task have {here}")
    out = batch.reset(seed)  # episode 0 of worlds seed + e
    keys = [f"obs_{s}" for s in sides] + ["state"] + [f"actions_{s}" for s in sides] + ["rewards_wolves", "rewards_targets", "terminated", "truncated"]
    rows: dict[str, list[np.ndarray]] = {k: [] for k in keys}
    final = {s: np.zeros_like(out[f"obs_{s}"]) for s in sides}
    length = np.zeros(count, np.int64)
    running = np.ones(count, bool)
    while running.any():
        acts = dict(zip(SIDES, batch.expert_actions()))
        if driver.learned:
            obs = out[f"obs_{side}"]
            acts[side] = driver.act(obs.reshape(-1, obs.shape[-1])).reshape(*obs.shape[:-1], 2)
        for s in sides:
            rows[f"obs_{s}"].append(out[f"obs_{s}"])
            rows[f"actions_{s}"].append(np.asarray(acts[s], np.float32))
        rows["state"].append(batch.state())
        out = batch.step(acts["wolves"], acts["targets"])
        for k in ("rewards_wolves", "rewards_targets", "terminated", "truncated"):
            rows[k].append(out[k])
        length += running
        ended = running & (out["outcome"] != 0)
        for s in sides:
            final[s][ended] = out[f"obs_{s}"][ended]
        running &= ~ended
    stacked = {k: np.stack(v, axis=1) for k, v in rows.items()}  # [E, T, ...]
    outcome = out["outcome"]
    return [{**{k: v[e, : length[e]] for k, v in stacked.items()}, **{f"final_obs_{s}": final[s][e] for s in sides}, "outcome": int(outcome[e])} for e in range(count)]


def upper_bound_bytes(task: str, episodes: int) -> int:
    """The most an npz dataset of ``episodes`` episodes of ``task`` can take (every episode
    running to ``world.max_steps``), in memory while recording and on disk: the figure
    ``wolfpack dataset`` warns with."""
    probe = BatchEnv(task=check_task(task), num_envs=1, learners="both", threads=1)
    n, m = probe.n_wolves, probe.n_targets
    floats = n * probe.wolf_obs_dim + m * probe.target_obs_dim + probe.state_dim + 3 * (n + m)  # observations, state, actions, rewards
    return int(episodes * probe.params["world"]["max_steps"] * (4 * floats + 2))


def write_npz(arrays: dict[str, np.ndarray], out: Path) -> Path:
    """``trajectories.npz`` in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    np.savez(out / "trajectories.npz", **arrays)
    return out / "trajectories.npz"


def load_npz(where: str | Path) -> dict[str, np.ndarray]:
    """The arrays of a ``wolfpack dataset`` npz folder (or the ``trajectories.npz`` itself)."""
    path = Path(where)
    if path.is_dir():
        path = path / "trajectories.npz"
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def episodes(arrays: dict[str, np.ndarray]) -> Iterator[dict[str, np.ndarray]]:
    """The episodes of :func:`load_npz`'s arrays, one dict each (the step arrays sliced, and
    the episode's ``final_obs_*``, ``seed`` and ``outcome``)."""
    offsets = arrays["episode_offsets"]
    finals = [k for k in arrays if k.startswith("final_")]
    per_step = [k for k in arrays if k not in ("episode_offsets", "seeds", "outcome", *finals)]
    for k in range(len(offsets) - 1):
        a, b = offsets[k], offsets[k + 1]
        yield {**{key: arrays[key][a:b] for key in per_step}, **{key: arrays[key][k] for key in finals}, "seed": int(arrays["seeds"][k]), "outcome": OUTCOMES[int(arrays["outcome"][k])]}


def minari_id(task: str, policy_name: str) -> str:
    """``wolfpack/<task>/<policy>-v0``, the policy's name cut to Minari's characters."""
    clean = re.sub(r"[^A-Za-z0-9_]+", "_", policy_name).strip("_") or "policy"
    return f"wolfpack/{task}/{clean}-v0"


def write_minari(arrays: dict[str, np.ndarray], task: str, out: Path, dataset_id: str, meta: dict):
    """A Minari dataset of the learning target's view (one target) under ``out``."""

    require("minari", "wolfpack dataset in Minari's format")
    import minari
    from minari.data_collector.episode_buffer import EpisodeBuffer

    buffers = []
    for k, ep in enumerate(episodes(arrays)):
        obs = np.concatenate([ep["obs_targets"][:, 0], ep["final_obs_targets"][None, 0]])
        buffers.append(
            EpisodeBuffer(
                id=k,
                seed=ep["seed"],
                observations=obs,
                actions=ep["actions_targets"][:, 0],
                rewards=list(ep["rewards_targets"][:, 0].astype(float)),
                terminations=list(ep["terminated"].astype(bool)),
                truncations=list(ep["truncated"].astype(bool)),
            )
        )
    before = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(out.resolve())  # where Minari writes
    try:
        return _create(minari, dataset_id, buffers, task, meta)
    finally:
        if before is None:
            del os.environ["MINARI_DATASETS_PATH"]
        else:
            os.environ["MINARI_DATASETS_PATH"] = before


def _create(minari, dataset_id: str, buffers: list, task: str, meta: dict):
    with warnings.catch_warnings():
        # Minari asks for a link to versioned code and an e-mail; the description carries the
        # command and dataset.json the versions instead.
        warnings.filterwarnings("ignore", message=r"`(code_permalink|author_email)` is set to None", category=UserWarning)
        return minari.create_dataset_from_buffers(
            dataset_id,
            buffers,
            env=gym_id(task),
            eval_env=gym_id(task),
            algorithm_name=meta["policy"],
            description=f"{meta['policy']} as the target on wolfpack task {task}, against its scripted wolves; episodes {meta['seed']}..{meta['seed'] + meta['episodes'] - 1}. Made by: {meta['command']}",
            data_format="hdf5",
            author="wolfpack dataset",
        )


def make(
    task: str,
    policy: Any,
    out: str | Path,
    *,
    side: str | None = None,
    episodes: int,
    seed: int = 0,
    fmt: str = "auto",
    threads: int | None = None,
    command: str = "",
    progress: Callable[[int], None] | None = None,
    force: bool = False,
) -> dict:
    """Collects and writes a dataset into ``out`` (a new or empty folder), then
    ``out/dataset.json`` (last: a folder without it is unfinished), and returns what it says:
    task, policy, side, episodes, seed, steps, outcomes, format, collect and write seconds,
    files and bytes.

    The dataset is written into a staging folder inside ``out`` and moved in only once it is
    complete, so a run that fails or is interrupted leaves ``out`` as it was. With ``force`` an
    ``out`` holding an earlier dataset is replaced then: the files an earlier ``wolfpack
    dataset`` wrote there (its manifest, :mod:`wolfpack.outputs`, lists them) go, nothing else
    does; an ``out`` holding other files is a ValueError."""
    check_task(task)
    side = side or policy_side(policy)
    driver = _driver(policy, side)
    one_learner = side == "targets" and task in single_target_tasks()
    if fmt not in ("auto", "minari", "npz"):
        raise ValueError(f"format must be auto, minari or npz, got {fmt!r}")
    if fmt == "minari" and not one_learner:
        raise ValueError(f"Minari's format holds one agent's view: a target policy on a task with one target ({', '.join(single_target_tasks())}); use npz")
    fmt = ("minari" if one_learner else "npz") if fmt == "auto" else fmt
    outputs = Outputs(out, "wolfpack dataset", force)
    try:
        meta = _make_into(outputs.start(), task, driver, side, episodes, seed, fmt, threads, command, progress)
        outputs.commit(last="dataset.json")
    finally:
        outputs.discard()
    return meta


def _make_into(out: Path, task: str, driver, side: str, episodes: int, seed: int, fmt: str, threads: int | None, command: str, progress: Callable[[int], None] | None) -> dict:
    """:func:`make`'s work, into ``out`` (new or empty)."""
    started = time.perf_counter()
    arrays = collect(task, driver, side, episodes=episodes, seed=seed, threads=threads, both_sides=fmt == "npz", progress=progress)
    collected = time.perf_counter() - started
    meta = {
        "task": task,
        "policy": driver.name,
        "side": side,
        "episodes": episodes,
        "seed": seed,
        "steps": int(arrays["episode_offsets"][-1]),
        "outcomes": {name: int((arrays["outcome"] == code).sum()) for code, name in enumerate(OUTCOMES) if (arrays["outcome"] == code).any()},
        "command": command,
    }
    if fmt == "npz":
        write_npz(arrays, out)
        meta["arrays"] = NPZ_KEYS
    else:
        meta["minari_id"] = minari_id(task, driver.name)
        write_minari(arrays, task, out, meta["minari_id"], meta)
    paths = sorted(p for p in out.rglob("*") if p.is_file())
    meta.update(
        format=fmt,
        collect_s=round(collected, 2),
        write_s=round(time.perf_counter() - started - collected, 2),
        files=[str(p.relative_to(out)) for p in paths],
        bytes=sum(p.stat().st_size for p in paths),
    )
    (out / "dataset.json").write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return meta
