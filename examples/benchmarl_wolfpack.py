#!/usr/bin/env python3
"""BenchMARL on wolfpack: MAPPO wolves against the scripted ``escape`` target, through the
batched TorchRL view (``wolfpack.torchrl_env.WolfpackEnv``), as a custom BenchMARL task.

BenchMARL pins its own TorchRL, so it lives in a virtualenv of its own (docs/learning.md,
"TorchRL and BenchMARL")::

    python -m venv .venv-benchmarl
    .venv-benchmarl/bin/pip install benchmarl .
    .venv-benchmarl/bin/python examples/benchmarl_wolfpack.py --frames 200000

The task class is what BenchMARL documents for external environments (a ``TaskClass`` whose
``get_env_fun`` builds the TorchRL env): one group per learning side, the observation of each
agent as its input, the world's global state for MAPPO's centralised critic. ``--task`` picks a
task of the benchmark suite (docs/tasks.md); ``--side`` the learning side.
"""

from __future__ import annotations

import argparse
import copy
import sys
import tempfile
from typing import Callable

from benchmarl.algorithms import IppoConfig, MappoConfig
from benchmarl.environments.common import TaskClass
from benchmarl.experiment import Experiment, ExperimentConfig
from benchmarl.models.mlp import MlpConfig
from torchrl.data import Composite
from torchrl.envs import EnvBase
from wolfpack.torchrl_env import WolfpackEnv


class WolfpackTask(TaskClass):
    """A wolfpack task for BenchMARL. ``config``: the keywords of :class:`WolfpackEnv` (``task``,
    ``learners``, ``opponent``, params overrides) and ``max_steps`` (the evaluation rollout's
    length, the task's ``world.max_steps`` by default)."""

    def get_env_fun(self, num_envs: int, continuous_actions: bool, seed: int | None, device) -> Callable[[], EnvBase]:
        config = copy.deepcopy(self.config)
        config.pop("max_steps", None)
        return lambda: WolfpackEnv(num_envs=num_envs, seed=seed or 0, device=device, **config)

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return False

    def has_render(self, env: EnvBase) -> bool:
        return False

    def max_steps(self, env: EnvBase) -> int:
        return int(self.config.get("max_steps") or env.batch.params["world"]["max_steps"])

    def group_map(self, env: EnvBase) -> dict[str, list[str]]:
        return env.group_map

    def observation_spec(self, env: EnvBase) -> Composite:
        spec = env.full_observation_spec_unbatched
        return Composite({group: Composite(observation=spec[group, "observation"], shape=spec[group].shape) for group in env.groups})

    def info_spec(self, env: EnvBase) -> Composite | None:
        return None

    def state_spec(self, env: EnvBase) -> Composite | None:
        return Composite(state=env.full_observation_spec_unbatched["state"])

    def action_spec(self, env: EnvBase) -> Composite:
        return env.full_action_spec_unbatched

    def action_mask_spec(self, env: EnvBase) -> Composite | None:
        return None

    @staticmethod
    def env_name() -> str:
        return "wolfpack"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--task", default="hunt-v1", help="a task of the benchmark suite (default hunt-v1)")
    p.add_argument("--side", choices=("wolves", "targets"), default="wolves")
    p.add_argument("--algo", choices=("mappo", "ippo"), default="mappo")
    p.add_argument("--frames", type=int, default=200_000, help="env steps x worlds to collect (default 200,000)")
    p.add_argument("--num-envs", type=int, default=100, help="worlds in the batch (default 100)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=None, help="BenchMARL's folder (default: a temporary one)")
    args = p.parse_args(argv)
    task = WolfpackTask(name=args.task.upper(), config={"task": args.task, "learners": args.side})
    config = ExperimentConfig.get_from_yaml()
    frames_per_batch = args.num_envs * 100
    config.sampling_device = config.train_device = "cpu"
    config.on_policy_collected_frames_per_batch = frames_per_batch
    config.on_policy_n_envs_per_worker = args.num_envs
    config.on_policy_minibatch_size = 4_000
    config.on_policy_n_minibatch_iters = 4
    config.max_n_frames = args.frames
    config.evaluation = True
    config.evaluation_interval = max(frames_per_batch, (args.frames // (2 * frames_per_batch)) * frames_per_batch)
    config.evaluation_episodes = 10
    config.loggers = ["csv"]
    config.create_json = True
    config.checkpoint_at_end = False
    algorithm = (MappoConfig if args.algo == "mappo" else IppoConfig).get_from_yaml()
    with tempfile.TemporaryDirectory() as scratch:
        config.save_folder = args.out or scratch
        experiment = Experiment(task=task, algorithm_config=algorithm, model_config=MlpConfig.get_from_yaml(), critic_model_config=MlpConfig.get_from_yaml(), seed=args.seed, config=config)
        experiment.run()
        print(f"BenchMARL {args.algo} on wolfpack {args.task} ({args.side}): {experiment.total_frames:,} frames in {experiment.total_time:.0f} s; folder {experiment.folder_name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
