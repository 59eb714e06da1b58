"""Same seed ⇒ bit-identical results, whatever the thread count or chunking; episode k of a run
with seed s is episode 0 of a run with seed s + k; a different seed gives a different episode."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import SHORT, layout_dict
from wolfpack import load_params, run_episodes

TRAJECTORY_ARRAYS = ("wolves", "targets", "energy", "interaction", "obstacle_poses")


@pytest.fixture(scope="module")
def params() -> dict:
    return load_params(overrides={"world.max_steps": 120})


def assert_identical(a: dict, b: dict) -> None:
    """Two episode results are equal bit for bit (trajectories included, if recorded)."""
    for key in ("seed", "outcome", "steps", "capture_step", "wolves", "targets"):
        assert a[key] == b[key], key
    for key in ("energy", "collisions"):
        assert a[key].dtype == b[key].dtype and a[key].tobytes() == b[key].tobytes(), key
    assert ("trajectory" in a) == ("trajectory" in b)
    if "trajectory" in a:
        ta, tb = a["trajectory"], b["trajectory"]
        for key in TRAJECTORY_ARRAYS:
            assert ta[key].shape == tb[key].shape and ta[key].tobytes() == tb[key].tobytes(), key
        assert ta["obstacle_shapes"] == tb["obstacle_shapes"]


@pytest.mark.parametrize("law", ["bvc", "formation"])
def test_other_laws_are_deterministic_across_threads_and_chunks(law):
    """bvc and formation memoise per-thread (the pack's assignment, the leader's path): a pure
    cache must not make results depend on which thread ran which episode before."""
    p = load_params(overrides={"world.max_steps": 150, "policies.wolves": law})
    one = run_episodes(p, 8, seed=11, record=True, threads=1)
    for other in (run_episodes(p, 8, seed=11, record=True, threads=2), run_episodes(p, 8, seed=11, record=True, threads=2, progress=lambda k: None, chunk=1)):
        for a, b in zip(one, other):
            assert_identical(a, b)
    # episode k of a run is episode 0 of a run seeded seed + k, whatever ran before on the thread
    assert_identical(run_episodes(p, 1, seed=16, record=True, threads=1)[0], one[5])


def test_thread_count_and_chunking_do_not_change_results(params):
    one = run_episodes(params, 6, seed=3, record=True, threads=1)
    variants = [
        run_episodes(params, 6, seed=3, record=True, threads=2),
        run_episodes(params, 6, seed=3, record=True, threads=2, progress=lambda k: None, chunk=1),
        run_episodes(params, 6, seed=3, record=True, threads=1, progress=lambda k: None, chunk=4),
    ]
    for other in variants:
        assert len(other) == len(one)
        for a, b in zip(one, other):
            assert_identical(a, b)


def test_recording_does_not_change_the_episode(params):
    recorded = run_episodes(params, 2, seed=8, record=True)
    plain = run_episodes(params, 2, seed=8)
    for a, b in zip(recorded, plain):
        a = {k: v for k, v in a.items() if k != "trajectory"}
        assert_identical(a, b)


def test_episode_k_of_seed_s_is_episode_0_of_seed_s_plus_k(params):
    run = run_episodes(params, 4, seed=10, record=True, threads=2)
    for k in range(4):
        assert run[k]["seed"] == 10 + k
        assert_identical(run[k], run_episodes(params, 1, seed=10 + k, record=True, threads=1)[0])


def test_different_seeds_give_different_episodes(params):
    a, b = run_episodes(params, 1, seed=0, record=True)[0], run_episodes(params, 1, seed=1, record=True)[0]
    assert a["trajectory"]["wolves"][0].tobytes() != b["trajectory"]["wolves"][0].tobytes()  # spawn
    assert a["trajectory"]["obstacle_poses"][0].tobytes() != b["trajectory"]["obstacle_poses"][0].tobytes()


def test_layout_episodes_are_deterministic_and_seeded(params):
    p = dict(params, capture=dict(params["capture"], count=None))
    layout = layout_dict()
    a = run_episodes(p, 2, seed=1, layout=layout, record=True, threads=1)
    b = run_episodes(p, 2, seed=1, layout=layout, record=True, threads=2)
    for x, y in zip(a, b):
        assert_identical(x, y)
    # Same start, different seed: identical row 0, different obstacle motion afterwards.
    t0, t1 = a[0]["trajectory"], a[1]["trajectory"]
    assert t0["wolves"][0].tobytes() == t1["wolves"][0].tobytes()
    assert t0["obstacle_poses"][1].tobytes() != t1["obstacle_poses"][1].tobytes()


def _npz(path) -> dict:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def test_cli_outputs_do_not_depend_on_threads(cli, tmp_path):
    outs = []
    for threads in ("1", "2"):
        out = tmp_path / f"t{threads}"
        proc = cli("hunt", "--episodes", "3", "--seed", "2", "--plots", "0", "--threads", threads, "--out", out, *SHORT)
        assert proc.returncode == 0, proc.stderr
        outs.append(out)
    s1, s2 = (json.loads((o / "summary.json").read_text()) for o in outs)
    for s in (s1, s2):  # wall-clock speed and the command line legitimately differ
        del s["env_steps_per_second"], s["command"]
    assert s1 == s2
    for k in range(3):
        a, b = (_npz(o / f"episode_{k:03d}" / "trajectory.npz") for o in outs)
        assert set(a) == set(b)
        for key in a:
            assert a[key].dtype == b[key].dtype and a[key].tobytes() == b[key].tobytes(), key
