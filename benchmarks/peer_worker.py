#!/usr/bin/env python3
"""Peer measurements for ``benchmarks/peers.py``, run in the peers' own virtualenv.

JaxMARL (JAX) and VMAS (torch) live in ``.venv-peers`` (``benchmarks/peers_venv.sh``), not in
wolfpack's ``.venv``. ``peers.py`` starts this script once per peer with that venv's python
(``--serve``) and talks to it over stdin/stdout, one JSON object per line each way, so that the
interleaving (round-robin over repeats) is still orchestrated by ``peers.py`` in one run while
compiled JAX functions and built environments persist between its rounds:

    {"op": "info", "peers": ["jaxmarl"]}                -> versions, whether those import
    {"op": "prepare", "id": ID, "kind": KIND, "num_envs": E, "target_s": S, "steps": N|null}
                                                        -> {"steps": ..., "compile_s": ..., ...}
    {"op": "measure", "id": ID}                         -> {"env_steps": ..., "seconds": ...}
    {"op": "close", "id": ID}  /  {"op": "quit"}

KIND is one of

* ``jaxmarl_loop``: JaxMARL ``SimpleTagMPE(num_good_agents=1, num_adversaries=5, num_obs=12,
  action_type="Continuous")``; one ``jax.jit`` of ``jax.vmap(env.step)`` over E worlds (the
  key is carried: split inside the jit into the next step's key and the E world keys), called
  from a Python loop with ``jax.block_until_ready`` on the new state and observations every
  step.
* ``jaxmarl_scan``: the same vmapped step inside a ``jax.lax.scan`` of T steps under one
  ``jax.jit``; the observations and rewards are folded into a checksum carried through the
  scan so that XLA cannot drop their computation. Compile time is reported, not timed.
* ``vmas``: ``vmas.make_env("simple_tag", num_envs=E, device="cpu", continuous_actions=True,
  num_good_agents=1, num_adversaries=5, num_landmarks=12, max_steps=None)``, ``env.step``.

An env-step is one world advanced one step (E per batched call). Actions are random, drawn
before the clock starts: a pool of 16 batches cycled through (JaxMARL: uniform in the
``Box(0, 1, (5,))`` continuous action space; VMAS: ``env.get_random_action``). JaxMARL's
``env.step`` resets a world inside the same call when its episode ends (``max_steps=25``, its
default), computing the reset every step either way; VMAS runs without resets (no horizon).

``prepare`` sizes the run: unless ``steps`` is given, it times growing runs (which are also the
warm-up) and picks the step count that takes about ``target_s`` seconds.

Run by hand for one number::

    .venv-peers/bin/python benchmarks/peer_worker.py jaxmarl_scan --num-envs 1024 --target-s 1
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

# The protocol owns the real stdout; everything else printed to fd 1 (jaxmarl prints notes about
# its optional submodules on import, XLA may log) goes to stderr.
_PROTO = os.fdopen(os.dup(1), "w", buffering=1)
os.dup2(2, 1)
sys.stdout = sys.stderr
os.environ.setdefault("JAX_PLATFORMS", "cpu")

from calibration import calibrate  # noqa: E402 (after the stdout redirect)
from peer_scenarios import COUNTS, vmas_simple_tag  # noqa: E402

POOL = 16  # pre-drawn action batches, cycled through


# ---------------------------------------------------------------------------------------------
# JaxMARL


_JAX_ENV = None
_JAX_START: dict[tuple[int, int], tuple] = {}


def jaxmarl_env():
    """One SimpleTagMPE for the whole process: its jitted methods are cached per instance."""
    global _JAX_ENV
    if _JAX_ENV is None:
        from jaxmarl.environments.mpe.default_params import CONTINUOUS_ACT
        from jaxmarl.environments.mpe.simple_tag import SimpleTagMPE

        _JAX_ENV = SimpleTagMPE(
            num_good_agents=COUNTS["targets"],
            num_adversaries=COUNTS["wolves"],
            num_obs=COUNTS["obstacles"],
            action_type=CONTINUOUS_ACT,
        )
    return _JAX_ENV


class JaxBase:
    def __init__(self, num_envs: int, seed: int = 0) -> None:
        import jax

        self.jax = jax
        self.E = num_envs
        self.env = env = jaxmarl_env()
        self.agents = list(env.agents)
        if (num_envs, seed) not in _JAX_START:  # the loop and the scan at one E start alike
            key = jax.random.PRNGKey(seed)
            key, k_reset, k_act = jax.random.split(key, 3)
            obs, state = jax.jit(jax.vmap(env.reset))(jax.random.split(k_reset, num_envs))
            dim = env.action_space(self.agents[0]).shape[0]
            # [POOL, E, agents, 5] in the Box(0, 1, (5,)) action space, drawn up-front.
            pool = jax.random.uniform(k_act, (POOL, num_envs, len(self.agents), dim))
            jax.block_until_ready((state, pool))
            _JAX_START[num_envs, seed] = ({a: int(o.shape[-1]) for a, o in obs.items()}, state, pool, key)
        self.obs_dims, self.state, self.pool, self.key = _JAX_START[num_envs, seed]

    def vstep(self, state, key, acts):
        """One step of all E worlds (traced inside a jit): E keys split from ``key``."""
        jax = self.jax
        keys = jax.random.split(key, self.E)
        actions = {a: acts[:, i] for i, a in enumerate(self.agents)}
        obs, state, rew, dones, _ = jax.vmap(self.env.step)(keys, state, actions)
        return obs, state, rew, dones

    def info(self) -> dict:
        return {
            "scenario": (
                f"jaxmarl SimpleTagMPE(num_good_agents={COUNTS['targets']}, num_adversaries={COUNTS['wolves']}, "
                f"num_obs={COUNTS['obstacles']}, action_type='Continuous'), jax.vmap over {self.E} worlds, "
                f"max_steps={self.env.max_steps} (autoreset inside env.step)"
            ),
            "agents": self.agents,
            "obs_dims": self.obs_dims,
            "declared_obs_dims": {a: list(self.env.observation_space(a).shape) for a in self.agents},
            "devices": [str(d) for d in self.jax.devices()],
        }


class JaxLoop(JaxBase):
    def __init__(self, num_envs: int, seed: int = 0) -> None:
        super().__init__(num_envs, seed)
        jax = self.jax

        def step(state, key, acts):
            key, sub = jax.random.split(key)  # the next step's key, inside the jit
            obs, state, rew, dones = self.vstep(state, sub, acts)
            return state, key, obs, rew, dones

        self.step = jax.jit(step)
        self.acts = [self.pool[i] for i in range(POOL)]
        t0 = time.perf_counter()
        out = self.step(self.state, self.key, self.acts[0])
        jax.block_until_ready(out)
        self.compile_s = time.perf_counter() - t0
        self.state, self.key = out[0], out[1]

    def run(self, steps: int) -> tuple[int, float]:
        block = self.jax.block_until_ready
        state, key, acts, step = self.state, self.key, self.acts, self.step
        t0 = time.perf_counter()
        for t in range(steps):
            state, key, obs, rew, dones = step(state, key, acts[t % POOL])
            block((state, obs))
        secs = time.perf_counter() - t0
        self.state, self.key = state, key
        return steps * self.E, secs


class JaxScan(JaxBase):
    def __init__(self, num_envs: int, seed: int = 0) -> None:
        super().__init__(num_envs, seed)
        self.compiled: dict[int, object] = {}
        self.compile_s: float | None = None

    def rollout_fn(self, T: int):
        jax, jnp = self.jax, self.jax.numpy
        if T in self.compiled:
            return self.compiled[T]

        def rollout(state, key, pool):
            def body(carry, t):
                state, key, check = carry
                key, sub = jax.random.split(key)
                obs, state, rew, dones = self.vstep(state, sub, pool[t % POOL])
                # Fold every observation and reward into the carry: outputs nobody reads would be
                # dead code to XLA, and the peers' timings include their observations.
                check = check + sum(jnp.sum(o) for o in obs.values()) + sum(jnp.sum(r) for r in rew.values())
                return (state, key, check), None

            (state, key, check), _ = jax.lax.scan(body, (state, key, jnp.float32(0)), jnp.arange(T))
            return state, key, check

        t0 = time.perf_counter()
        fn = jax.jit(rollout).lower(self.state, self.key, self.pool).compile()
        self.compile_s = time.perf_counter() - t0
        self.compiled[T] = fn
        return fn

    def run(self, steps: int) -> tuple[int, float]:
        fn = self.rollout_fn(steps)
        t0 = time.perf_counter()
        state, key, check = fn(self.state, self.key, self.pool)
        self.jax.block_until_ready((state, check))
        secs = time.perf_counter() - t0
        self.state, self.key = state, key
        return steps * self.E, secs

    def calibrate(self, target_s: float) -> int:
        """Probes with a scan of 8 steps, then with one sized from it to take about a tenth of
        ``target_s``, then compiles the sized one (each T is its own compile; the last one's
        time is reported as compile_s)."""
        probe = 8
        self.run(probe)  # compile + first run
        _, secs = self.run(probe)
        if secs < target_s / 20:
            probe = max(probe + 1, round(target_s / 10 * probe / max(secs, 1e-9)))
            self.run(probe)
            _, secs = self.run(probe)
        steps = max(3, round(target_s * probe / max(secs, 1e-9)))
        self.compiled.clear()
        self.run(steps)  # compile (timed into compile_s) + warm run
        return steps


# ---------------------------------------------------------------------------------------------
# VMAS


class Vmas:
    def __init__(self, num_envs: int, seed: int = 0) -> None:
        import torch

        self.torch = torch
        self.E = num_envs
        t0 = time.perf_counter()
        self.env = env = vmas_simple_tag(num_envs, seed)
        # Drawn up-front, within each agent's action range (VMAS's own sampler).
        self.pool = [[env.get_random_action(a) for a in env.agents] for _ in range(POOL)]
        self.compile_s = time.perf_counter() - t0  # construction, for the record

    def run(self, steps: int) -> tuple[int, float]:
        env, pool = self.env, self.pool
        t0 = time.perf_counter()
        for t in range(steps):
            env.step(pool[t % POOL])
        return steps * self.E, time.perf_counter() - t0

    def info(self) -> dict:
        return {
            "scenario": (f"vmas simple_tag, num_envs={self.E}, cpu, num_good_agents={COUNTS['targets']}, num_adversaries={COUNTS['wolves']}, num_landmarks={COUNTS['obstacles']}, max_steps=None"),
            "torch_threads": self.torch.get_num_threads(),
            "agents": [a.name for a in self.env.agents],
        }


KINDS = {"jaxmarl_loop": JaxLoop, "jaxmarl_scan": JaxScan, "vmas": Vmas}


def versions() -> dict:
    from importlib import metadata

    out = {"python": sys.version.split()[0], "executable": sys.executable}
    for pkg in ("jax", "jaxlib", "jaxmarl", "vmas", "torch", "numpy"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = None
    return out


PEER_MODULES = {"jaxmarl": ("jax", "jaxmarl.environments.mpe.simple_tag"), "vmas": ("torch", "vmas")}


def importable(peers: list[str] | None = None) -> dict:
    """Which peers can run here: {peer: None} or {peer: "why not"} (importing only those asked)."""
    res = {}
    for kind in peers or list(PEER_MODULES):
        mods = PEER_MODULES[kind]
        try:
            for m in mods:
                __import__(m)
            res[kind] = None
        except Exception as e:  # noqa: BLE001 - reported, not raised
            res[kind] = f"{type(e).__name__}: {e}"
    return res


def prepare(kind: str, num_envs: int, target_s: float, steps: int | None) -> tuple[object, dict]:
    obj = KINDS[kind](num_envs)
    if steps is None:
        steps = obj.calibrate(target_s) if hasattr(obj, "calibrate") else calibrate(obj.run, target_s)
    elif kind == "jaxmarl_scan":
        obj.run(steps)  # compile + warm run
    else:
        obj.run(min(steps, 20))  # warm-up
    obj.steps = steps
    info = obj.info() | {"steps_per_run": steps, "env_steps_per_run": steps * num_envs, "compile_s": getattr(obj, "compile_s", None)}
    return obj, info


def serve() -> int:
    live: dict[str, object] = {}
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            req = json.loads(line)
            op = req["op"]
            if op == "quit":
                break
            if op == "info":
                reply = {"versions": versions(), "importable": importable(req.get("peers"))}
            elif op == "prepare":
                obj, reply = prepare(req["kind"], int(req["num_envs"]), float(req.get("target_s", 1.5)), req.get("steps"))
                live[req["id"]] = obj
            elif op == "measure":
                obj = live[req["id"]]
                env_steps, secs = obj.run(obj.steps)
                reply = {"env_steps": env_steps, "seconds": secs}
            elif op == "close":
                live.pop(req["id"], None)
                reply = {}
            else:
                raise ValueError(f"unknown op {op!r}")
        except Exception as e:  # noqa: BLE001 - the error goes back to peers.py, which skips the row
            reply = {"error": f"{type(e).__name__}: {e}"}
        _PROTO.write(json.dumps(reply) + "\n")
        _PROTO.flush()
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("kind", nargs="?", choices=sorted(KINDS), help="one measurement (omit with --serve)")
    ap.add_argument("--serve", action="store_true", help="line protocol on stdin/stdout (peers.py)")
    ap.add_argument("--num-envs", type=int, default=64)
    ap.add_argument("--target-s", type=float, default=1.5, help="seconds per measurement (sizes the step count)")
    ap.add_argument("--steps", type=int, default=None, help="fixed steps per measurement instead")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    if args.serve:
        return serve()
    if not args.kind:
        ap.error("give a KIND or --serve")
    obj, info = prepare(args.kind, args.num_envs, args.target_s, args.steps)
    runs = [obj.run(obj.steps) for _ in range(args.repeats)]
    rates = sorted(s / t for s, t in runs)
    info |= {"seconds": [t for _, t in runs], "env_steps_per_second": rates[len(rates) // 2], "versions": versions()}
    _PROTO.write(json.dumps(info, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
