"""``wolfpack`` end to end, in a fresh interpreter: bad input fails cleanly, a good run writes
the documented files."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import SHORT, layout_dict
from wolfpack.cli.hunt import JSON_KEYS

# --- bad input ----------------------------------------------------------------------------

# (arguments after "hunt", a fragment the one-line message must contain)
BAD_ARGS = [
    (["--set", "world.wolvs=3"], "world.wolvs"),  # unknown key
    (["--set", "colour=red"], "colour"),
    (["--set", "world.wolves=five"], "world.wolves"),  # wrong type
    (["--set", "world.border=[0,0,1]"], "world.border"),
    (["--set", "world.wolves=0"], "world.wolves"),  # zero / negative counts
    (["--set", "world.targets=-1"], "world.targets"),
    (["--set", "obstacles.static_circles=-1"], "obstacles.static_circles"),
    (["--set", "obstacles.circle_radius=[0,1]"], "obstacles.circle_radius"),  # radii
    (["--set", "capture.distance=-0.8"], "capture.distance"),
    (["--set", "agents.wolf.v_max=0"], "agents.wolf.v_max"),  # speeds
    (["--set", "world.ts=0"], "world.ts: must be in (0, 1] s, got 0"),
    (["--set", "world.max_steps=0"], "world.max_steps"),
    (["--set", "world.border=[5,-10,5,10]"], "world.border"),  # x_min ≥ x_max
    (["--set", "capture.count=6"], "capture.count"),  # more than the wolves
    (["--set", "capture.arrive_tolerance=0"], "capture.arrive_tolerance"),  # docs/world-and-laws.md §1.7 success rules
    (["--set", "capture.arrive_tolerance=-0.2"], "capture.arrive_tolerance"),
    (["--set", "capture.cornered=1"], "capture.cornered"),
    (["--set", "capture.cornered=sometimes"], "capture.cornered"),
    (["--set", "capture.rule=surround"], "capture.rule"),
    (["--set", "obstacles.static_polygons=500"], "spawn: could not place static polygon"),  # infeasible
    (["--set", "world.wolves=200"], "too small for world.wolves = 200"),  # the crowd, not the obstacle it crowds out
    (["--set", "policies.targets=flee"], "policies.targets"),  # unknown policy names
    (["--set", "policies.wolves=lion"], "policies.wolves"),
    (["--targets", "flee"], "--targets"),
    (["--wolves", "lion"], "--wolves"),
    (["--set", "world.wolves"], "key=value"),  # malformed --set
    (["--episodes", "0"], "--episodes"),
    (["--seed", "-1"], "--seed"),
    (["--threads", "0"], "--threads"),
    (["--params", "/nonexistent/params.yaml"], "/nonexistent/params.yaml"),
    (["--layout", "/nonexistent/layout.json"], "/nonexistent/layout.json"),
    (["--seed", str(2**64 - 1)], "--seed"),  # seeds S + k are u64
    (["--bogus"], "--bogus"),
]


def assert_clean_failure(proc, fragment: str) -> None:
    """Non-zero exit, one line on stderr naming the problem, no traceback or panic, nothing on
    stdout that could pass for a result."""
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode != 0, proc.stdout
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("wolfpack: "), lines[0]
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in proc.stderr and "panicked" not in proc.stderr
    assert proc.stdout == ""


@pytest.mark.parametrize(("args", "fragment"), BAD_ARGS, ids=[" ".join(a) for a, _ in BAD_ARGS])
def test_bad_input_fails_with_one_line_and_writes_nothing(cli, tmp_path, args, fragment):
    out = tmp_path / "out"
    extra = [] if "--episodes" in args else ["--episodes", "2"]
    proc = cli("hunt", *args, *extra, "--json", "--out", out, timeout=60)
    assert_clean_failure(proc, fragment)
    assert not out.exists()  # everything is checked before DIR is created


def _bad_layouts() -> list[tuple[str, str, str]]:
    outside = layout_dict()
    outside["wolves"][2] = [0.0, 10.5, 0.0]
    overlapping = layout_dict()
    overlapping["targets"] = [[5.2, 5.0, 0.0]]  # inside the circle
    wrong_schema = layout_dict()
    wrong_schema["wolves"] = "five"
    return [
        ("outside", json.dumps(outside), "wolf 2 at (0, 10.5) is outside the arena"),
        ("overlap", json.dumps(overlapping), "target 0 overlaps obstacle 0"),
        ("malformed", '{"wolves": [[0, 0, 0]],', "not valid JSON"),
        ("schema", json.dumps(wrong_schema), "layout: wolves"),
        ("unknown kind", json.dumps({**layout_dict(), "obstacles": [{"kind": "blob", "center": [0, 0]}]}), "layout: obstacles"),
    ]


@pytest.mark.parametrize(("name", "text", "fragment"), _bad_layouts(), ids=[b[0] for b in _bad_layouts()])
def test_bad_layout_fails_with_one_line_and_writes_nothing(cli, tmp_path, name, text, fragment):
    path = tmp_path / "layout.json"
    path.write_text(text)
    out = tmp_path / "out"
    assert_clean_failure(cli("hunt", "--layout", path, "--episodes", "2", "--out", out, timeout=60), fragment)
    assert not out.exists()


def test_explicit_capture_count_larger_than_the_layout_pack_is_rejected(cli, tmp_path):
    layout = layout_dict()
    layout["wolves"] = layout["wolves"][:3]
    path = tmp_path / "layout.json"
    path.write_text(json.dumps(layout))
    assert_clean_failure(cli("hunt", "--layout", path, "--set", "capture.count=4", "--episodes", "1"), "capture.count")


def test_bad_params_file_fails_with_one_line(cli, tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text("world:\n  ts: [1,\n")
    assert_clean_failure(cli("hunt", "--params", path), "not valid YAML")


def test_out_that_is_a_file_is_rejected_and_left_alone(cli, tmp_path):
    path = tmp_path / "taken"
    path.write_text("keep me")
    assert_clean_failure(cli("hunt", "--episodes", "1", "--out", path, *SHORT), "not a directory")
    assert path.read_text() == "keep me"


def test_formation_hunts_and_its_bad_parameters_are_named(cli):
    done = cli("hunt", "--wolves", "formation", "--episodes", "2", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["episodes"] == 2
    assert_clean_failure(cli("hunt", "--wolves", "formation", "--episodes", "1", "--set", "formation.bump_delta=1.5"), "formation.bump_delta")
    assert_clean_failure(cli("hunt", "--wolves", "formation", "--episodes", "1", "--set", "formation.gain=2"), "formation.gain")


def test_bvc_hunts_and_its_bad_parameters_are_named(cli):
    done = cli("hunt", "--wolves", "bvc", "--episodes", "3", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["episodes"] == 3
    assert_clean_failure(cli("hunt", "--wolves", "bvc", "--episodes", "1", "--set", "bvc.safety_radius=-1"), "bvc.safety_radius")
    assert_clean_failure(cli("hunt", "--wolves", "bvc", "--episodes", "1", "--set", "bvc.assignment_period=0"), "bvc.assignment_period")
    assert_clean_failure(cli("hunt", "--wolves", "bvc", "--episodes", "1", "--set", "bvc.speed=2"), "bvc.speed")


@pytest.mark.parametrize(
    ("error", "status", "fragment"),
    [
        (RuntimeError("internal error in wolfpack core (please report): boom\nat line 3"), 3, "wolfpack: internal error in wolfpack core (please report): boom at line 3"),
        (ValueError("capture.count: too\nmany"), 2, "wolfpack: error: capture.count: too many"),
        (PermissionError(13, "Permission denied", "/root/x"), 1, "wolfpack: error: /root/x: Permission denied"),
        (BrokenPipeError(32, "Broken pipe"), 1, "wolfpack: error: Broken pipe"),  # no file: no empty "::"
        (KeyboardInterrupt(), 130, "wolfpack: interrupted"),
    ],
)
def test_main_maps_exceptions_to_one_line_and_a_status(monkeypatch, capsys, error, status, fragment):
    """A core bug (RuntimeError), bad input (ValueError), a file system error and Ctrl-C each end
    the program with one line and their own exit status, never a traceback."""
    from wolfpack.cli import hunt, main

    def fail(*args, **kwargs):
        raise error

    monkeypatch.setattr(hunt, "run_episodes", fail)
    with pytest.raises(SystemExit) as e:
        main(["hunt", "--episodes", "1"])
    assert e.value.code == status
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == fragment + "\n"


# --- help ---------------------------------------------------------------------------------


def test_help_explains_every_option_the_scenario_and_the_outputs(cli):
    proc = cli("hunt", "--help")
    assert proc.returncode == 0
    for word in [
        "--params",
        "--wolves",
        "--targets",
        "--episodes",
        "--seed",
        "--set",
        "--layout",
        "--out",
        "--plots",
        "--json",
        "--threads",
        "captured",
        "collision",
        "timeout",
        "summary.json",
        "trajectory.npz",
        "trajectory.png",
        "curves.png",
        "summary.png",
        "interaction.png",
        "episode.mp4",
        "--video",
        "examples:",
        "env_steps_per_second",
    ]:
        assert word in proc.stdout, word
    top = cli("--help")
    assert top.returncode == 0 and "hunt" in top.stdout and "bench" in top.stdout and "replay" in top.stdout
    replay = cli("replay", "--help")
    assert replay.returncode == 0 and all(w in replay.stdout for w in ("EPISODE_DIR", "--out", "--no-video", "episode.mp4", "trajectory.npz"))
    bench = cli("bench", "--help")
    assert bench.returncode == 0 and "BatchEnv" in bench.stdout and "--num-envs" in bench.stdout and "--threads" in bench.stdout


# --- a good run ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """``wolfpack hunt --episodes 3 --seed 4 --out DIR --json`` (max_steps 120), run once."""
    from conftest import run_cli

    out = tmp_path_factory.mktemp("run") / "out"
    proc = run_cli("hunt", "--episodes", "3", "--seed", "4", "--out", out, "--json", "--plots", "2", *SHORT)
    assert proc.returncode == 0, proc.stderr
    return proc, out


def test_json_output_is_one_object_with_the_documented_keys(small_run):
    proc, _ = small_run
    summary = json.loads(proc.stdout)  # the whole of stdout is one JSON object
    assert set(JSON_KEYS) <= set(summary)
    assert summary["episodes"] == 3
    assert math.isclose(summary["capture_rate"] + summary["collision_rate"] + summary["timeout_rate"], 1.0)
    assert summary["env_steps_per_second"] > 0
    assert proc.stderr == ""  # no progress bar when stderr is not a terminal


def test_summary_json_holds_the_summary_params_command_and_details(small_run):
    proc, out = small_run
    summary = json.loads((out / "summary.json").read_text())
    printed = json.loads(proc.stdout)
    for key in JSON_KEYS:
        if key != "env_steps_per_second":
            assert summary[key] == printed[key], key
    assert summary["seed"] == 4
    assert summary["params"]["world"]["max_steps"] == 120
    assert summary["command"][:2] == ["wolfpack", "hunt"] and "--json" in summary["command"]
    details = summary["episodes_detail"]
    assert [d["seed"] for d in details] == [4, 5, 6]
    for d in details:
        assert d["outcome"] in ("captured", "collision", "timeout")
        assert 1 <= d["steps"] <= 120
        assert (d["capture_step"] is not None) == (d["outcome"] == "captured")
        assert d["cornered_step"] is None or 1 <= d["cornered_step"] <= d["steps"]
        assert len(d["energy"]) == len(d["collisions"]) == 6
    assert summary["cornered_episodes"] == sum(d["cornered_step"] is not None for d in details)
    captured = sorted(d["capture_step"] for d in details if d["outcome"] == "captured")
    assert summary["median_capture_steps"] == (float(np.median(captured)) if captured else None)
    assert math.isclose(summary["mean_energy"], np.mean([sum(d["energy"]) for d in details]))
    assert not list(out.glob(".*.tmp"))


def test_plots_are_written_for_the_first_episodes_only(small_run):
    _, out = small_run
    assert (out / "summary.png").stat().st_size > 0
    for k in (0, 1):
        assert (out / f"episode_{k:03d}" / "trajectory.png").stat().st_size > 0
        assert (out / f"episode_{k:03d}" / "curves.png").stat().st_size > 0
    assert sorted(p.name for p in (out / "episode_002").iterdir()) == ["trajectory.npz"]


def test_trajectory_npz_shapes_dtypes_and_row_semantics(small_run):
    _, out = small_run
    params = json.loads((out / "summary.json").read_text())["params"]
    details = json.loads((out / "summary.json").read_text())["episodes_detail"]
    ts, mass = params["world"]["ts"], params["agents"]["wolf"]["mass"]
    for k, d in enumerate(details):
        with np.load(out / f"episode_{k:03d}" / "trajectory.npz", allow_pickle=False) as z:
            a = {key: z[key] for key in z.files}
        t, n, m = d["steps"], 5, 1
        assert a["wolves"].shape == (t + 1, n, 5) and a["wolves"].dtype == np.float64
        assert a["targets"].shape == (t + 1, m, 5) and a["targets"].dtype == np.float64
        assert a["energy"].shape == (t + 1, n + m) and a["energy"].dtype == np.float64
        assert a["interaction"].shape == (t, n + m, n + m) and a["interaction"].dtype == np.uint8
        assert set(np.unique(a["interaction"])) <= {0, 1}
        assert a["collisions"].tolist() == d["collisions"]
        assert str(a["outcome"]) == d["outcome"]
        assert int(a["capture_step"]) == (-1 if d["capture_step"] is None else d["capture_step"])
        assert int(a["seed"]) == d["seed"]
        k_obs = 12
        assert a["obstacle_poses"].shape == (t + 1, k_obs, 3)
        assert a["obstacle_kind"].shape == a["obstacle_radius"].shape == (k_obs,)
        assert a["obstacle_vertices"].shape[0] == k_obs and a["obstacle_vertices"].shape[2] == 2
        circles = np.char.find(a["obstacle_kind"], "circle") >= 0
        assert circles.sum() == 2 and np.isnan(a["obstacle_vertices"][circles]).all()
        # Row 0 is the initial state: at rest, no energy spent.
        agents = np.concatenate([a["wolves"], a["targets"]], axis=1)
        assert (agents[0, :, 3:] == 0).all()
        assert (a["energy"][0] == 0).all()
        # Row t holds the speed of step t: energy grows by ½ m v² per step (docs/world-and-laws.md §1.2) ...
        np.testing.assert_allclose(np.diff(a["energy"], axis=0), 0.5 * mass * agents[1:, :, 3] ** 2, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(a["energy"][-1], d["energy"], rtol=1e-12)
        # ... and the position moves by v Ts along the previous heading (unicycle, §1.2).
        step = agents[1:, :, :2] - agents[:-1, :, :2]
        heading = np.stack([np.cos(agents[:-1, :, 2]), np.sin(agents[:-1, :, 2])], axis=-1)
        np.testing.assert_allclose(step, agents[1:, :, 3:4] * ts * heading, atol=1e-9)
        assert ((agents[:, :, 2] >= 0) & (agents[:, :, 2] < 2 * math.pi)).all()


#: The modes each law may be in (docs/world-and-laws.md §1.8), wolves' and targets' (escape).
LAW_MODES_OF = {
    "seed000": {"chase", "follow", "lost", "early_exit", "emergency", "close_partner", "avoid_edge"},
    "bvc": {"wait", "lost", "direct", "cell_inside", "cell_edge", "cell_vertex"},
    "formation": {"wait", "lost", "lead", "encircle"},
    "escape": {"wander", "flee", "coast", "emergency", "avoid_edge", "avoid_hold", "ended"},
}


@pytest.mark.parametrize("law", ["seed000", "bvc", "formation"])
def test_trajectories_record_the_mode_of_each_law(cli, tmp_path, law):
    """``hunt --out``'s trajectory.npz holds each agent's law mode per state (row 0: none), as
    codes into mode_names (the core's vocabulary), each a mode of that law, and the modes change
    over an episode."""
    from wolfpack import _core

    out = tmp_path / law
    proc = cli("hunt", "--wolves", law, "--episodes", "3", "--seed", "2", "--plots", "0", "--no-html", "--out", out, *SHORT)
    assert proc.returncode == 0, proc.stderr
    varied = {"wolves": 0, "targets": 0}
    for k in range(3):
        with np.load(out / f"episode_{k:03d}" / "trajectory.npz", allow_pickle=False) as z:
            a = {key: z[key] for key in z.files}
        rows = a["wolves"].shape[0]
        assert a["wolf_mode"].shape == (rows, 5) and a["wolf_mode"].dtype == np.uint8
        assert a["target_mode"].shape == (rows, 1) and a["target_mode"].dtype == np.uint8
        assert a["mode_names"].tolist() == list(_core.LAW_MODES) and _core.LAW_MODES[0] == "none"
        assert (a["wolf_mode"][0] == 0).all() and (a["target_mode"][0] == 0).all(), "row 0: no step yet"
        names = np.asarray(_core.LAW_MODES)
        wolves, targets = set(names[a["wolf_mode"][1:]].ravel()), set(names[a["target_mode"][1:]].ravel())
        assert wolves <= LAW_MODES_OF[law], f"episode {k}: {wolves - LAW_MODES_OF[law]} are no {law} modes"
        assert targets <= LAW_MODES_OF["escape"], f"episode {k}: {targets - LAW_MODES_OF['escape']} are no escape modes"
        for side, codes in (("wolves", a["wolf_mode"]), ("targets", a["target_mode"])):
            varied[side] += any(len(np.unique(codes[1:, i])) > 1 for i in range(codes.shape[1]))
    assert varied["wolves"] and varied["targets"], f"{law}: the modes never change over an episode ({varied})"


def test_table_output_without_json(cli, tmp_path):
    proc = cli("hunt", "--episodes", "2", "--targets", "still", *SHORT)
    assert proc.returncode == 0, proc.stderr
    for word in ("captured", "collision", "timeout", "median capture steps", "env steps per second", "still"):
        assert word in proc.stdout, word


def test_a_failed_rerun_leaves_the_earlier_run_intact(cli, tmp_path):
    out = tmp_path / "out"
    assert cli("hunt", "--episodes", "1", "--plots", "0", "--out", out, *SHORT).returncode == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert (out / "summary.json").exists()
    # Invalid parameters: caught before DIR is touched, the earlier run's files stay as they were.
    assert_clean_failure(cli("hunt", "--out", out, "--set", "world.ts=0"), "world.ts")
    assert (out / "summary.json").exists()
    # A used folder is refused without --force, and nothing in it is touched.
    assert_clean_failure(cli("hunt", "--episodes", "1", "--out", out, *SHORT), "--force")
    assert (out / "summary.json").exists()
    # --force with valid parameters whose spawn fails while running: the new run was written
    # beside DIR, so the failure costs the earlier run nothing, and leaves no temporary folder.
    assert_clean_failure(cli("hunt", "--episodes", "1", "--out", out, "--force", "--set", "obstacles.static_polygons=500"), "spawn")
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    rerun = cli("hunt", "--episodes", "2", "--plots", "0", "--seed", "9", "--out", out, "--force", *SHORT)
    assert rerun.returncode == 0
    assert json.loads((out / "summary.json").read_text())["seed"] == 9


# --- layouts ------------------------------------------------------------------------------


def test_layout_run_starts_from_the_layout_and_seeds_move_the_obstacles(cli, tmp_path, layout_file):
    out = tmp_path / "out"
    proc = cli("hunt", "--layout", layout_file, "--episodes", "2", "--seed", "5", "--plots", "1", "--out", out, "--json", *SHORT)
    assert proc.returncode == 0, proc.stderr
    layout = layout_dict()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["params"]["world"]["wolves"] == 5 and summary["params"]["world"]["targets"] == 1
    assert summary["layout"] == layout
    runs = []
    for k in (0, 1):
        with np.load(out / f"episode_{k:03d}" / "trajectory.npz", allow_pickle=False) as z:
            a = {key: z[key] for key in z.files}
        runs.append(a)
        np.testing.assert_array_equal(a["wolves"][0, :, :3], layout["wolves"])
        np.testing.assert_array_equal(a["targets"][0, :, :3], layout["targets"])
        assert list(a["obstacle_kind"]) == ["moving_circle", "moving_polygon"]
        np.testing.assert_array_equal(a["obstacle_poses"][0], [[5.0, 5.0, 0.0], [-5.0, 5.0, 0.0]])
        assert a["obstacle_radius"][0] == 0.8
        poly = layout["obstacles"][1]
        np.testing.assert_allclose(a["obstacle_vertices"][1], np.asarray(poly["vertices"]) - poly["center"], atol=1e-12)
    # Same start, different seeds: the obstacles drift differently from the first step on.
    assert not np.array_equal(runs[0]["obstacle_poses"][1], runs[1]["obstacle_poses"][1])
    assert not np.array_equal(runs[0]["wolves"], runs[1]["wolves"]) or not np.array_equal(runs[0]["targets"], runs[1]["targets"])


def test_a_layout_brings_its_own_pack_size_and_capture_count(cli, tmp_path):
    layout = layout_dict()
    layout["wolves"] = layout["wolves"][:3]
    path = tmp_path / "layout.json"
    path.write_text(json.dumps(layout))
    out = tmp_path / "out"
    proc = cli("hunt", "--layout", path, "--episodes", "1", "--plots", "1", "--out", out, *SHORT)
    assert proc.returncode == 0, proc.stderr
    params = json.loads((out / "summary.json").read_text())["params"]
    assert params["world"]["wolves"] == 3 and params["capture"]["count"] == 3  # ⌈0.8 · 3⌉
    with np.load(out / "episode_000" / "trajectory.npz") as z:
        assert z["wolves"].shape[1:] == (3, 5) and z["interaction"].shape[1:] == (4, 4)


# --- bench --------------------------------------------------------------------------------


def test_bench_reports_throughput_for_one_thread_and_all_cores(cli):
    proc = cli("bench", "--episodes", "2", "--num-envs", "3", "--batch-steps", "4", "--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["runs"][0]["threads"] == 1
    for row in report["runs"]:
        assert row["env_steps_per_second"] > 0 and row["episodes_per_second"] > 0 and row["episodes"] == 2
    assert report["batch"][0]["threads"] == 1
    for row in report["batch"]:
        assert row["env_steps"] == 12 and row["env_steps_per_second"] > 0
    table = cli("bench", "--episodes", "1", "--batch-steps", "2", "--threads", "2")
    assert table.returncode == 0 and "env-steps/s" in table.stdout


def test_cornered_targets_are_counted_and_end_episodes_only_when_asked(cli, tmp_path):
    """docs/world-and-laws.md §1.7: without capture.cornered cornering is only counted; with it a cornered target is
    a success of its own (outcome ``cornered``), so bvc's success rate is at least its capture
    rate without it, on the same episodes."""
    plain = json.loads(cli("hunt", "--wolves", "bvc", "--episodes", "40", "--seed", "0", "--json").stdout)
    out = tmp_path / "run"
    proc = cli("hunt", "--wolves", "bvc", "--episodes", "40", "--seed", "0", "--json", "--plots", "0", "--set", "capture.cornered=true", "--out", out)
    assert proc.returncode == 0, proc.stderr
    asked = json.loads(proc.stdout)
    assert plain["cornered_rate"] == 0.0 and plain["cornered_episodes"] > 0
    assert plain["success_rate"] == plain["capture_rate"]
    assert asked["cornered_rate"] > 0.0
    assert asked["success_rate"] == asked["capture_rate"] + asked["cornered_rate"] >= plain["capture_rate"]
    details = json.loads((out / "summary.json").read_text())["episodes_detail"]
    for d in details:
        if d["outcome"] == "cornered":  # cornered at its last step, never captured
            assert d["cornered_step"] == d["steps"] and d["capture_step"] is None
    k = next(i for i, d in enumerate(details) if d["outcome"] == "cornered")
    arrays = np.load(out / f"episode_{k:03d}" / "trajectory.npz")
    assert str(arrays["outcome"]) == "cornered"
    assert int(arrays["cornered_step"]) == details[k]["steps"] == int(arrays["target_capture_step"][0])
    assert int(arrays["capture_step"]) == -1


def test_version_and_python_dash_m(cli):
    import subprocess
    import sys

    import wolfpack

    done = cli("--version")
    assert done.returncode == 0 and done.stdout.strip() == f"wolfpack {wolfpack.__version__}"
    # A bare `wolfpack` shows what it can do (the help), not an error about a missing command.
    bare = cli()
    assert bare.returncode == 0 and bare.stdout.startswith("usage: wolfpack") and "hunt" in bare.stdout and bare.stderr == ""
    as_module = subprocess.run([sys.executable, "-m", "wolfpack", "hunt", "--episodes", "1", "--json"], capture_output=True, text=True, timeout=120)
    assert as_module.returncode == 0, as_module.stderr
    assert json.loads(as_module.stdout)["episodes"] == 1


def test_force_replaces_an_earlier_run_and_refuses_other_files(cli, tmp_path):
    """A 2-episode run after a 3-episode one in the same folder, with --force: no episode_002 of
    the old run beside the new summary; a folder with a user's own file in it is refused."""
    out = tmp_path / "out"
    assert cli("hunt", "--episodes", "3", "--plots", "0", "--out", out, *SHORT).returncode == 0
    (out / "notes.txt").write_text("mine")
    assert_clean_failure(cli("hunt", "--episodes", "2", "--plots", "0", "--out", out, "--force", *SHORT), "notes.txt")
    assert (out / "notes.txt").read_text() == "mine" and (out / "episode_002").is_dir()
    (out / "notes.txt").unlink()
    assert cli("hunt", "--episodes", "2", "--plots", "0", "--seed", "5", "--out", out, "--force", *SHORT).returncode == 0
    assert sorted(p.name for p in out.glob("episode_*")) == ["episode_000", "episode_001"]
    assert json.loads((out / "summary.json").read_text())["seed"] == 5
    assert not list(out.rglob(".*.tmp"))


def test_out_keeps_a_bounded_number_of_trajectories(cli, tmp_path):
    """--out writes trajectory.npz for the first 20 episodes (or --plots when larger) unless
    --trajectories says otherwise; the summary covers every episode either way."""

    def npz(out):
        return sorted(p.parent.name for p in out.glob("episode_*/trajectory.npz"))

    args = ("--episodes", "24", "--set", "world.max_steps=20")
    assert cli("hunt", *args, "--plots", "0", "--out", tmp_path / "a").returncode == 0
    assert npz(tmp_path / "a") == [f"episode_{k:03d}" for k in range(20)]
    assert json.loads((tmp_path / "a" / "summary.json").read_text())["episodes"] == 24
    assert cli("hunt", *args, "--trajectories", "all", "--plots", "0", "--out", tmp_path / "c").returncode == 0
    assert len(npz(tmp_path / "c")) == 24
    assert cli("hunt", *args, "--trajectories", "0", "--plots", "1", "--out", tmp_path / "d").returncode == 0
    assert npz(tmp_path / "d") == [] and (tmp_path / "d" / "episode_000" / "trajectory.png").is_file()
    bad = cli("hunt", "--episodes", "2", "--trajectories", "some", "--out", tmp_path / "e")
    assert bad.returncode == 2 and "expected an integer >= 0 or 'all', got 'some'" in bad.stderr and not (tmp_path / "e").exists()


def test_a_run_of_more_than_a_gigabyte_says_so_first(capsys):
    import argparse

    from wolfpack import _core
    from wolfpack.cli import hunt

    def kept(episodes, plots, trajectories):
        return hunt.kept_trajectories(argparse.Namespace(episodes=episodes, plots=plots, trajectories=trajectories))

    # 20 by default, or --plots when larger; never more than the episodes.
    assert (kept(100, 20, None), kept(100, 25, None), kept(5, 20, None), kept(100, 25, 3), kept(7, 0, "all")) == (20, 25, 5, 3, 7)

    params = _core.default_params()
    hunt._warn_if_large(argparse.Namespace(episodes=100_000, plots=20, trajectories="all"), params)
    assert "keeps 100,000 trajectory.npz files, about 8.0 GB" in capsys.readouterr().err
    hunt._warn_if_large(argparse.Namespace(episodes=100_000, plots=20, trajectories=None), params)
    assert capsys.readouterr().err == ""
