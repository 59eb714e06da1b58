"""The writers of ``wolfpack hunt --out`` (logs.py, plots.py), on synthetic episode results so
that they are tested apart from the simulator."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from conftest import synthetic_result
from wolfpack import _core, logs, plots
from wolfpack.cli.run_files import RunWriter

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
PARAMS = _core.default_params()


def test_trajectory_arrays_have_the_documented_keys_shapes_and_dtypes():
    n, m, steps = 4, 2, 9
    a = logs.trajectory_arrays(synthetic_result(n, m, steps), PARAMS)
    expected = {
        "wolves": (np.float64, (steps + 1, n, 5)),
        "targets": (np.float64, (steps + 1, m, 5)),
        "energy": (np.float64, (steps + 1, n + m)),
        "interaction": (np.uint8, (steps, n + m, n + m)),
        "obstacle_poses": (np.float64, (steps + 1, 2, 3)),
        "obstacle_radius": (np.float64, (2,)),
        "obstacle_vertices": (np.float64, (2, 5, 2)),
        "border": (np.float64, (4,)),
        "capture_step": (np.int64, ()),
        "ts": (np.float64, ()),
        "capture_distance": (np.float64, ()),
    }
    for key, (dtype, shape) in expected.items():
        assert a[key].dtype == dtype, key
        assert a[key].shape == shape, key
    assert a["outcome"].shape == () and str(a["outcome"]) == "captured"
    assert list(a["obstacle_kind"]) == ["moving_circle", "static_polygon"]
    assert int(a["capture_step"]) == steps
    assert float(a["ts"]) == PARAMS["world"]["ts"]


def test_vertices_are_nan_padded_and_circles_have_none():
    r = synthetic_result()
    r["trajectory"]["obstacle_shapes"].append({"kind": "moving_polygon", "radius": 1.0, "vertices": [[1, 0], [0, 1], [-1, 0], [0, -1], [0.5, -0.5], [0.9, -0.1], [0.95, -0.05]]})
    r["trajectory"]["obstacle_poses"] = np.concatenate([r["trajectory"]["obstacle_poses"], r["trajectory"]["obstacle_poses"][:, :1]], axis=1)
    v = logs.trajectory_arrays(r, PARAMS)["obstacle_vertices"]
    assert v.shape == (3, 7, 2)
    assert np.isnan(v[0]).all()
    assert not np.isnan(v[1, :5]).any() and np.isnan(v[1, 5:]).all()
    assert not np.isnan(v[2]).any()


def test_no_capture_is_minus_one():
    a = logs.trajectory_arrays(synthetic_result(outcome="timeout"), PARAMS)
    assert int(a["capture_step"]) == -1 and str(a["outcome"]) == "timeout"


def test_missing_trajectory_is_a_value_error():
    r = synthetic_result()
    del r["trajectory"]
    with pytest.raises(ValueError, match="record=True"):
        logs.trajectory_arrays(r, PARAMS)


def test_npz_round_trip_needs_no_pickle(tmp_path):
    a = logs.trajectory_arrays(synthetic_result(), PARAMS)
    logs.write_trajectory(tmp_path / "t.npz", a)
    with np.load(tmp_path / "t.npz", allow_pickle=False) as back:
        assert set(back.files) == set(a)
        for key in a:
            np.testing.assert_array_equal(back[key], a[key], err_msg=key)
    assert str(logs.load_trajectory(tmp_path / "t.npz")["outcome"]) == "captured"


def test_episode_detail_is_plain_json():
    d = logs.episode_detail(synthetic_result(n=3, m=1, outcome="collision"))
    assert json.loads(json.dumps(d)) == d
    assert d["outcome"] == "collision" and d["capture_step"] is None
    assert len(d["energy"]) == len(d["collisions"]) == 4


def test_json_is_written_atomically(tmp_path):
    path = tmp_path / "summary.json"
    logs.write_json_atomic(path, {"a": 1})
    logs.write_json_atomic(path, {"a": 2})
    assert json.loads(path.read_text()) == {"a": 2}
    assert [p.name for p in tmp_path.iterdir()] == ["summary.json"]  # no temp file left
    with pytest.raises(ValueError):
        logs.write_json_atomic(path, {"a": math.nan})  # NaN is not JSON
    assert json.loads(path.read_text()) == {"a": 2}


def test_polygon_world_vertices_are_centre_plus_rotated_local():
    local = np.array([[1.0, 0.0], [0.0, 2.0], [-1.0, 0.0], [np.nan, np.nan]])
    patch = plots.obstacle_outline("moving_polygon", 2.0, local, np.array([3.0, 4.0, math.pi / 2]))
    world = patch.get_xy()[:3]  # matplotlib closes the ring with a copy of the first vertex
    np.testing.assert_allclose(world, [[3.0, 5.0], [1.0, 4.0], [3.0, 3.0]], atol=1e-12)
    circle = plots.obstacle_outline("static_circle", 0.5, np.empty((0, 2)), np.array([1.0, 2.0, 0.3]))
    assert tuple(circle.center) == (1.0, 2.0) and circle.radius == 0.5


def test_wolf_target_distance_is_to_the_nearest_target():
    a = {"wolves": np.zeros((1, 2, 5)), "targets": np.zeros((1, 2, 5))}
    a["wolves"][0, 1, :2] = [3.0, 4.0]
    a["targets"][0, 0, :2] = [0.0, 1.0]
    a["targets"][0, 1, :2] = [3.0, 0.0]
    np.testing.assert_allclose(plots.wolf_target_distance(a), [[1.0, 4.0]])


@pytest.mark.parametrize("m", [1, 2])
def test_episode_plots_are_pngs(tmp_path, m):
    a = logs.trajectory_arrays(synthetic_result(n=5, m=m), PARAMS)
    plots.plot_trajectory(a, tmp_path / "trajectory.png")
    plots.plot_curves(a, tmp_path / "curves.png")
    for name in ("trajectory.png", "curves.png"):
        assert (tmp_path / name).read_bytes()[:8] == PNG_MAGIC


@pytest.mark.parametrize("outcomes", [["captured", "timeout", "captured", "collision"], ["timeout"]])
def test_summary_plot_with_and_without_captures(tmp_path, outcomes):
    details = [logs.episode_detail(synthetic_result(seed=i, outcome=o)) for i, o in enumerate(outcomes)]
    plots.plot_summary(details, tmp_path / "summary.png")
    assert (tmp_path / "summary.png").read_bytes()[:8] == PNG_MAGIC


def test_run_writer_plots_only_the_first_episodes_and_writes_the_summary_last(tmp_path):
    out = tmp_path / "run"
    writer = RunWriter(out, PARAMS, plots=1)
    assert not out.exists()  # nothing is created before the first episode arrives
    results = [synthetic_result(seed=s) for s in (0, 1)]
    for k, r in enumerate(results):
        writer.episode(k, r)
    assert sorted(p.name for p in (out / "episode_000").iterdir()) == ["curves.png", "interaction.png", "trajectory.npz", "trajectory.png"]
    assert sorted(p.name for p in (out / "episode_001").iterdir()) == ["trajectory.npz"]
    assert not (out / "summary.json").exists()
    writer.finish({"episodes": 2, "episodes_detail": [logs.episode_detail(r) for r in results]})
    assert json.loads((out / "summary.json").read_text())["episodes"] == 2
    assert (out / "summary.png").exists()


def test_run_writer_removes_a_stale_summary_at_once(tmp_path):
    (tmp_path / "summary.json").write_text("{}")
    RunWriter(tmp_path, PARAMS, plots=0)
    assert not (tmp_path / "summary.json").exists()


def _with_modes(n: int = 3, m: int = 1, steps: int = 7) -> dict:
    """A synthetic trajectory with law modes, as the core records them."""
    r = synthetic_result(n, m, steps)
    rng = np.random.default_rng(0)
    r["trajectory"]["wolf_mode"] = rng.integers(1, len(_core.LAW_MODES), (steps + 1, n)).astype(np.uint8)
    r["trajectory"]["target_mode"] = rng.integers(1, len(_core.LAW_MODES), (steps + 1, m)).astype(np.uint8)
    r["trajectory"]["wolf_mode"][0] = r["trajectory"]["target_mode"][0] = 0
    return logs.trajectory_arrays(r, PARAMS)


def test_law_modes_are_written_with_their_names_and_checked():
    a = _with_modes()
    assert a["wolf_mode"].dtype == a["target_mode"].dtype == np.uint8
    assert a["mode_names"].tolist() == list(_core.LAW_MODES)
    logs.check_trajectory(a)
    # Files written before modes were recorded have none, and pass.
    old = logs.trajectory_arrays(synthetic_result(), PARAMS)
    assert not {"wolf_mode", "target_mode", "mode_names"} & set(old)
    logs.check_trajectory(old)
    for key, value, fragment in (
        ("wolf_mode", lambda a: a["wolf_mode"][:, :2], "wolf_mode: expected shape [T+1, N]"),
        ("target_mode", lambda a: a["target_mode"][1:], "target_mode: expected shape [T+1, M]"),
        ("wolf_mode", lambda a: a["wolf_mode"] * 0 + len(_core.LAW_MODES), "wolf_mode: codes must lie in"),
        ("target_mode", lambda a: a["target_mode"].astype(float), "target_mode: must hold integer codes"),
        ("mode_names", lambda a: np.array([1, 2]), "mode_names: must be a list of strings"),
    ):
        bad = dict(a)
        bad[key] = value(a)
        with pytest.raises(ValueError, match=re.escape(fragment)):
            logs.check_trajectory(bad)


def test_the_mode_names_are_the_documented_table():
    """docs/world-and-laws.md §1.8 lists every mode by code, as the core names them."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "world-and-laws.md").read_text(encoding="utf-8")
    section = text.split("### 1.8 The laws' modes", 1)[1].split("\n## ", 1)[0]
    rows = [line.split("|")[1:3] for line in section.splitlines() if line.startswith("| ") and line.split("|")[1].strip().isdigit()]
    assert [(int(code), name.strip().strip("`")) for code, name in rows] == list(enumerate(_core.LAW_MODES))
