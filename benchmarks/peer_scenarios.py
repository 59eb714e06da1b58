"""The scenario every peer is built at, shared by ``peers.py`` and ``peer_contenders.py`` (main
virtualenv) and ``peer_worker.py`` (``.venv-peers``): standard library only at import, so both
can use it."""

from __future__ import annotations

from typing import Any

#: The documented scenario's counts: 5 pursuers, 1 evader, 12 obstacles.
COUNTS = {"wolves": 5, "targets": 1, "obstacles": 12}


def vmas_simple_tag(num_envs: int, seed: int = 0) -> Any:
    """VMAS ``simple_tag`` on the CPU at :data:`COUNTS`, continuous actions, no horizon, reset,
    with torch's generator seeded (for ``env.get_random_action``)."""
    import torch
    import vmas

    env = vmas.make_env(
        scenario="simple_tag",
        num_envs=num_envs,
        device="cpu",
        continuous_actions=True,
        seed=seed,
        max_steps=None,
        num_good_agents=COUNTS["targets"],
        num_adversaries=COUNTS["wolves"],
        num_landmarks=COUNTS["obstacles"],
    )
    env.reset()
    torch.manual_seed(seed)
    return env
