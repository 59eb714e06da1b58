"""The observation layout comes from the core (``wolfpack.observation_layout``): its blocks tile
every observation, the entries they name hold what they say, and docs/interface.md's table and
its default sizes are the same layout."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import wolfpack

ROOT = Path(__file__).resolve().parents[1]
INTERFACE = ROOT / "docs" / "interface.md"
OPTIONAL = {"env.last_sighting": True, "env.interaction_row": True}


@pytest.mark.parametrize("overrides", [{}, OPTIONAL, {"world.wolves": 3, "world.targets": 2, "env.lidar.rays": 5, **OPTIONAL}])
def test_the_blocks_tile_each_sides_observation(overrides):
    batch = wolfpack.BatchEnv(num_envs=1, learners="both", **overrides)
    for side, dim in (("wolves", batch.wolf_obs_dim), ("targets", batch.target_obs_dim)):
        blocks = wolfpack.observation_layout(side, **overrides)
        assert [b["start"] for b in blocks] == list(np.cumsum([0] + [b["size"] for b in blocks[:-1]]))
        assert blocks[-1]["start"] + blocks[-1]["size"] == dim
        assert ("interaction" in [b["name"] for b in blocks]) == bool(overrides)


def test_the_named_entries_hold_what_they_say():
    batch = wolfpack.BatchEnv(num_envs=2, learners="both", seed=3)
    out = batch.reset()
    for _ in range(7):
        out = batch.step(np.zeros((2, batch.n_wolves, 2), np.float32), np.zeros((2, batch.n_targets, 2), np.float32))
    max_steps = batch.params["world"]["max_steps"]
    for side, obs in (("wolves", out["obs_wolves"]), ("targets", out["obs_targets"])):
        at = {b["name"]: slice(b["start"], b["start"] + b["size"]) for b in wolfpack.observation_layout(side)}
        np.testing.assert_allclose(obs[..., at["clock"]], 7 / max_steps, rtol=1e-6)
        heading = obs[..., at["heading"]]
        np.testing.assert_allclose((heading**2).sum(-1), 1.0, rtol=1e-5)
        lidar = obs[..., at["lidar"]]
        assert lidar.shape[-1] == batch.params["env"]["lidar"]["rays"] and (lidar >= 0).all() and (lidar <= 1).all()


def test_a_bad_side_is_named():
    with pytest.raises(ValueError, match="side must be 'wolves' or 'targets', got 'dogs'"):
        wolfpack.observation_layout("dogs")


# --- docs/interface.md ------------------------------------------------------------------------

#: Which block a row of the documents' table describes, by a phrase of its text.
ROW_KEYS = [
    ("own speed", "speed"),
    ("own turn rate", "turn_rate"),
    ("sin θ, cos θ", "heading"),
    ("x_min", "walls"),
    ("max_steps` |", "clock"),
    ("speed cap", "speed_cap"),
    ("per target, in index order", "targets"),
    ("wolves, nearest first", "wolves"),
    ("other wolves, nearest first", "wolves"),
    ("lidar", "lidar"),
    ("sighted", "last_sighting"),
    ("interaction matrix", "interaction"),
]


def table_rows() -> list[tuple[str, str, str]]:
    """(entries, wolf, target) of every row of the Observations table."""
    text = INTERFACE.read_text(encoding="utf-8")
    table = text.split("| entries | wolf | target |\n|---|---|---|\n", 1)[1].split("\n\n", 1)[0]
    return [tuple(cell.strip() for cell in row.strip("|").split(" | ")) for row in table.splitlines()]


def block_of(cell: str) -> str:
    return next(name for phrase, name in ROW_KEYS if phrase in cell)


def test_the_documents_table_lists_each_sides_blocks_in_the_cores_order():
    documented = {"wolves": [], "targets": []}
    for entries, wolf, target in table_rows():
        # (" |" ends each cell, so that the clock's row, which ends in `world.max_steps`, is told
        # from the last sighting's, which names it midway.)
        if wolf != "—":
            documented["wolves"].append(block_of(f"{wolf} |"))
        if target != "—":
            documented["targets"].append(block_of(f"{wolf if target == 'same' else target} |"))
    for side in documented:
        assert documented[side] == [b["name"] for b in wolfpack.observation_layout(side, **OPTIONAL)], side


def test_the_documents_default_sizes_are_the_cores():
    text = " ".join(INTERFACE.read_text(encoding="utf-8").split())
    for side, noun in (("wolves", "wolf"), ("targets", "target")):
        m = re.search(rf"\*\*(\d+)\*\* for a {noun} \(([^)]*)\)", text)
        assert m, f"docs/interface.md states no default size for a {noun}"
        blocks = wolfpack.observation_layout(side)
        assert int(m.group(1)) == blocks[-1]["start"] + blocks[-1]["size"]
        # "0–8 common, 9–13 the target, ...": the common block, then the side's blocks in order.
        spans = [tuple(int(x) for x in re.match(r"(\d+)(?:–(\d+))?", part.strip()).groups(default=None) if x is not None) for part in m.group(2).split(",")]
        common = [b for b in blocks if b["name"] in ("speed", "turn_rate", "heading", "walls", "clock")]
        own = [b for b in blocks if b not in common]
        expected = [(0, common[-1]["start"] + common[-1]["size"] - 1)] + [(b["start"],) if b["size"] == 1 else (b["start"], b["start"] + b["size"] - 1) for b in own]
        assert spans == expected, (side, m.group(2))
