"""Hardening, the Python side: bounded input (file size, nesting, YAML alias bombs),
numbers read as YAML 1.2 reads them, Python's exception conventions across the API, a command
line that never damages an earlier run and stops at once on Ctrl-C, and a replay that checks
the file it is given."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import wolfpack
from conftest import SHORT, layout_dict, popen_interruptible, synthetic_result
from test_cli import assert_clean_failure
from wolfpack import _core, cli, logs, outputs
from wolfpack._checks import MAX_THREADS
from wolfpack.config import MAX_DEPTH, MAX_FILE_BYTES, MAX_NODES, check_tree, load_layout, load_params, parse_override
from wolfpack.interrupt import CtrlC

# --- numbers as YAML 1.2 reads them -----------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("1e-3", 0.001),
        ("1E5", 1e5),
        ("-2.5e+2", -250.0),
        ("1e3", 1000.0),
        ("1.0e3", 1000.0),
        (".5e1", 5.0),
        ("8", 8),
        ("-3", -3),
        ("1_000", 1000),
        ("0.1", 0.1),
        (".inf", float("inf")),
        ("e3", "e3"),
        ("1e", "1e"),
        ("1.2.3", "1.2.3"),
    ],
)
def test_scientific_notation_is_a_float(text, value):
    key, parsed = parse_override(f"world.ts={text}")
    assert key == "world.ts" and parsed == value and type(parsed) is type(value)


def test_scientific_notation_in_a_params_file_and_on_the_command_line(tmp_path, cli):
    path = tmp_path / "p.yaml"
    path.write_text("world:\n  ts: 5e-2\n  max_steps: 2\n")
    assert load_params(path)["world"]["ts"] == 0.05
    assert load_params(overrides=dict([parse_override("world.ts=2e-2")]))["world"]["ts"] == 0.02
    done = cli("hunt", "--episodes", "1", "--set", "world.ts=5e-2", "--set", "world.max_steps=3", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["total_steps"] == 3


# --- bounded input ----------------------------------------------------------------------------


def _nested(levels: int, leaf=1):
    x = leaf
    for _ in range(levels):
        x = [x]
    return x


def _alias_bomb(levels: int = 9) -> str:
    """YAML "billion laughs": 9**levels strings from a few hundred bytes."""
    lines = ["lol0: &l0 [" + ", ".join(['"lol"'] * 9) + "]"]
    lines += [f"lol{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * 9) + "]" for i in range(1, levels)]
    return "world:\n  wolves: 5\nbomb:\n" + "\n".join("  " + line for line in lines) + "\n"


def test_check_tree_limits_are_exact_and_iterative():
    check_tree(_nested(MAX_DEPTH), "x")
    with pytest.raises(ValueError, match=f"x: nested deeper than {MAX_DEPTH} levels"):
        check_tree(_nested(MAX_DEPTH + 1), "x")
    with pytest.raises(ValueError, match="nested deeper"):
        check_tree(_nested(200_000), "x")  # no RecursionError, no crash
    check_tree(list(range(MAX_NODES - 1)), "x")  # the list and its values
    with pytest.raises(ValueError, match=f"x: more than {MAX_NODES} values"):
        check_tree(list(range(MAX_NODES)), "x")
    shared = [1, 2]  # an object used several times counts every time (3 values each)
    check_tree([shared] * 5, "x", max_nodes=16)
    with pytest.raises(ValueError, match="more than 15"):
        check_tree([shared] * 5, "x", max_nodes=15)
    loop: list = []
    loop.append(loop)
    with pytest.raises(ValueError, match="nested deeper"):
        check_tree(loop, "x")
    check_tree(load_params(), "params")
    check_tree(layout_dict(), "layout")


def test_alias_bomb_in_a_params_file_is_refused_at_once(tmp_path):
    path = tmp_path / "bomb.yaml"
    path.write_text(_alias_bomb())
    assert path.stat().st_size < 2000
    t0 = time.perf_counter()
    with pytest.raises(ValueError) as e:
        load_params(path)
    assert time.perf_counter() - t0 < 2.0
    assert str(path) in str(e.value) and f"more than {MAX_NODES} values" in str(e.value) and "\n" not in str(e.value)


def test_self_referencing_yaml_is_refused(tmp_path):
    path = tmp_path / "loop.yaml"
    path.write_text("world: &a\n  x: *a\n")
    with pytest.raises(ValueError, match="nested deeper"):
        load_params(path)


@pytest.mark.parametrize("levels", [MAX_DEPTH + 1, 100_000])
def test_deep_params_and_layout_files_are_refused_by_name(tmp_path, levels):
    params = tmp_path / "deep.yaml"
    params.write_text("world:\n  x: " + "[" * levels + "]" * levels + "\n")
    with pytest.raises(ValueError, match=f"params {params}: nested deeper than {MAX_DEPTH} levels"):
        load_params(params)
    layout = tmp_path / "deep.json"
    layout.write_text('{"wolves": ' + "[" * levels + "]" * levels + "}")
    with pytest.raises(ValueError, match=f"layout {layout}: nested deeper than {MAX_DEPTH} levels"):
        load_layout(layout)


def test_files_over_the_size_limit_are_refused_by_name(tmp_path):
    params = tmp_path / "big.yaml"
    params.write_text("# " + "x" * MAX_FILE_BYTES + "\n")
    with pytest.raises(ValueError, match=f"params {params}: larger than 1 MiB"):
        load_params(params)
    layout = tmp_path / "big.json"
    layout.write_text(json.dumps({**layout_dict(), "pad": "x" * MAX_FILE_BYTES}))
    with pytest.raises(ValueError, match=f"layout {layout}: larger than 1 MiB"):
        load_layout(layout)
    # Just under the limit is read (and then judged on its content).
    params.write_text("# " + "x" * (MAX_FILE_BYTES - 10) + "\n")
    assert load_params(params) == _core.default_params()


def test_a_params_file_that_is_not_utf8_is_a_value_error(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_bytes(b"world:\n  wolves: \xff\xfe\n")
    with pytest.raises(ValueError, match="not UTF-8"):
        load_params(path)


def test_an_integer_too_long_to_convert_is_a_value_error_naming_the_source(tmp_path):
    digits = "9" * 5000
    path = tmp_path / "p.yaml"
    path.write_text(f"world:\n  wolves: {digits}\n")
    with pytest.raises(ValueError, match=f"params {path}: Exceeds the limit"):
        load_params(path)
    layout = tmp_path / "l.json"
    layout.write_text(f'{{"wolves": {digits}}}')
    with pytest.raises(ValueError, match=f"layout {layout}: Exceeds the limit"):
        load_layout(layout)
    with pytest.raises(ValueError, match="--set world.wolves: Exceeds the limit"):
        parse_override(f"world.wolves={digits}")


def test_deep_or_huge_overrides_and_python_dicts_are_refused_by_name():
    deep = _nested(100_000)
    with pytest.raises(ValueError, match="--set world.border: value nested deeper"):
        parse_override("world.border=" + "[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match="override world.border: nested deeper"):
        load_params(overrides={"world.border": deep})
    with pytest.raises(ValueError, match="override a.a.a"):
        load_params(overrides={".".join(["a"] * (MAX_DEPTH + 1)): 1})
    with pytest.raises(ValueError, match="override world.x: more than"):
        load_params(overrides={"world.x": list(range(MAX_NODES + 1))})
    with pytest.raises(ValueError, match="params: nested deeper"):
        wolfpack.BatchEnv({"world": {"x": deep}})
    with pytest.raises(ValueError, match="override world.border: nested deeper"):
        wolfpack.BatchEnv(**{"world.border": deep})
    with pytest.raises(ValueError, match="override world.border: nested deeper"):
        wolfpack.parallel_env(world__border=deep)
    with pytest.raises(ValueError, match="params: nested deeper"):
        wolfpack.run_episodes({"world": {"x": deep}}, 1)
    with pytest.raises(ValueError, match="layout: nested deeper"):
        wolfpack.run_episodes(None, 1, layout={**layout_dict(), "wolves": deep})
    with pytest.raises(ValueError, match="layout: nested deeper"):
        wolfpack.BatchEnv().reset_world(0, layout={**layout_dict(), "wolves": deep})
    loop: dict = {}
    loop["world"] = loop
    with pytest.raises(ValueError, match="params: nested deeper"):
        wolfpack.BatchEnv(loop)


def test_overrides_must_be_a_mapping():
    with pytest.raises(TypeError, match="overrides must be a mapping of dotted keys"):
        load_params(overrides=[("world.wolves", 3)])
    with pytest.raises(TypeError, match="overrides must be a mapping"):
        load_params(overrides=[])
    with pytest.raises(TypeError, match="params must be None, a path or a dict"):
        wolfpack.BatchEnv(params=5)


def test_bounded_input_on_the_command_line(cli, tmp_path):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(_alias_bomb())
    assert_clean_failure(cli("hunt", "--params", bomb, timeout=30), "more than")
    deep = "[" * 60_000 + "]" * 60_000  # crashed the process before; one argument holds at most 128 KiB
    assert_clean_failure(cli("hunt", "--set", f"world.border={deep}", timeout=30), "--set world.border: value nested deeper than 32 levels")
    deep_file = tmp_path / "deep.yaml"
    deep_file.write_text("world:\n  x: " + deep + "\n")
    assert_clean_failure(cli("hunt", "--params", deep_file, timeout=30), "nested deeper than 32 levels")
    layout = tmp_path / "deep.json"
    layout.write_text('{"wolves": ' + deep + "}")
    assert_clean_failure(cli("hunt", "--layout", layout, timeout=30), "nested deeper than 32 levels")


# --- exception types across the Python API ----------------------------------------------------


def _batch():
    return wolfpack.BatchEnv(num_envs=2)


def _escape():
    return gymnasium.make("wolfpack/Escape-v0")


BAD_VALUES = {
    "BatchEnv(seed=2**64)": lambda: wolfpack.BatchEnv(seed=2**64),
    "BatchEnv(seed=-1)": lambda: wolfpack.BatchEnv(seed=-1),
    "BatchEnv(num_envs=3, seed=2**64-2)": lambda: wolfpack.BatchEnv(num_envs=3, seed=2**64 - 2),  # world 2's seed
    "BatchEnv(num_envs=0)": lambda: wolfpack.BatchEnv(num_envs=0),
    "BatchEnv(num_envs=-1)": lambda: wolfpack.BatchEnv(num_envs=-1),
    "BatchEnv(threads=0)": lambda: wolfpack.BatchEnv(threads=0),
    "BatchEnv(threads=100000)": lambda: wolfpack.BatchEnv(num_envs=2, threads=100_000),  # hung before
    f"BatchEnv(threads={MAX_THREADS + 1})": lambda: wolfpack.BatchEnv(threads=MAX_THREADS + 1),
    "BatchEnv(autoreset='no')": lambda: wolfpack.BatchEnv(autoreset="no"),
    "BatchEnv(autoreset=1)": lambda: wolfpack.BatchEnv(autoreset=1),
    "reset(seed=-1)": lambda: _batch().reset(seed=-1),
    "reset(-1)": lambda: _batch().reset(-1),
    "reset(seed=2**64-1) over 2 worlds": lambda: _batch().reset(seed=2**64 - 1),
    "reset_world(0, seed=-1)": lambda: _batch().reset_world(0, seed=-1),
    "reset_world(0, seed=2**64)": lambda: _batch().reset_world(0, seed=2**64),
    "reset_world(-1)": lambda: _batch().reset_world(-1),
    "reset_world(2)": lambda: _batch().reset_world(2),
    "world_state(-1)": lambda: _batch().world_state(-1),
    "run_episodes(seed=-1)": lambda: wolfpack.run_episodes(None, 1, seed=-1),
    "run_episodes(seed=2**64)": lambda: wolfpack.run_episodes(None, 1, seed=2**64),
    "run_episodes(2, seed=2**64-1)": lambda: wolfpack.run_episodes(None, 2, seed=2**64 - 1),
    "run_episodes(episodes=0)": lambda: wolfpack.run_episodes(None, 0),
    "run_episodes(chunk=-1)": lambda: wolfpack.run_episodes(None, 1, chunk=-1),
    "run_episodes(chunk=0)": lambda: wolfpack.run_episodes(None, 1, chunk=0),
    "run_episodes(chunk=1.5)": lambda: wolfpack.run_episodes(None, 1, chunk=1.5),
    "run_episodes(record='yes')": lambda: wolfpack.run_episodes(None, 1, record="yes"),
    "run_episodes(threads=0)": lambda: wolfpack.run_episodes(None, 1, threads=0),
    f"run_episodes(threads={MAX_THREADS + 1})": lambda: wolfpack.run_episodes(None, 1, threads=MAX_THREADS + 1),
    "parallel_env(seed=-1)": lambda: wolfpack.parallel_env(seed=-1),
    "parallel_env().reset(seed=-1)": lambda: wolfpack.parallel_env().reset(seed=-1),
    "parallel_env().reset(seed=2**64)": lambda: wolfpack.parallel_env().reset(seed=2**64),
    "parallel_env(shared_space='yes')": lambda: wolfpack.parallel_env(learners="both", shared_space="yes"),
    "env(seed=2**64)": lambda: wolfpack.env(seed=2**64),
    "env().reset(seed=-1)": lambda: wolfpack.env().reset(seed=-1),
    "Escape-v0 reset(seed=-1)": lambda: _escape().reset(seed=-1),
    "Escape-v0 reset(seed=2**64)": lambda: _escape().reset(seed=2**64),
    "Escape-v0(seed=-1)": lambda: gymnasium.make("wolfpack/Escape-v0", seed=-1),
    "make_vec_env(seed=2**64)": lambda: wolfpack.make_vec_env(num_envs=1, seed=2**64),
    "make_vec_env(threads=0)": lambda: wolfpack.make_vec_env(num_envs=1, threads=0),
    "make_vec_env().seed(-1)": lambda: wolfpack.make_vec_env(num_envs=1).seed(-1),
}

WRONG_TYPES = {
    "BatchEnv(seed='1')": lambda: wolfpack.BatchEnv(seed="1"),
    "BatchEnv(seed=True)": lambda: wolfpack.BatchEnv(seed=True),
    "BatchEnv(seed=1.0)": lambda: wolfpack.BatchEnv(seed=1.0),
    "BatchEnv(num_envs=2.0)": lambda: wolfpack.BatchEnv(num_envs=2.0),
    "BatchEnv(num_envs='2')": lambda: wolfpack.BatchEnv(num_envs="2"),
    "BatchEnv(num_envs=True)": lambda: wolfpack.BatchEnv(num_envs=True),
    "BatchEnv(threads=1.5)": lambda: wolfpack.BatchEnv(threads=1.5),
    "reset(seed='1')": lambda: _batch().reset(seed="1"),
    "reset(seed=True)": lambda: _batch().reset(seed=True),
    "reset_world(0.0)": lambda: _batch().reset_world(0.0),
    "world_state('0')": lambda: _batch().world_state("0"),
    "run_episodes(1.0)": lambda: wolfpack.run_episodes(None, 1.0),
    "run_episodes(seed='0')": lambda: wolfpack.run_episodes(None, 1, seed="0"),
    "run_episodes(threads=2.0)": lambda: wolfpack.run_episodes(None, 1, threads=2.0),
    "run_episodes(progress=3)": lambda: wolfpack.run_episodes(None, 1, progress=3),
    "parallel_env(seed=True)": lambda: wolfpack.parallel_env(seed=True),
    "parallel_env().reset(options=[])": lambda: wolfpack.parallel_env().reset(options=[]),
    "Escape-v0 reset(options=[1])": lambda: _escape().reset(options=[1]),
    "load_params(overrides=[...])": lambda: load_params(overrides=[("world.wolves", 3)]),
}


@pytest.mark.parametrize("call", BAD_VALUES.values(), ids=BAD_VALUES.keys())
def test_bad_values_are_value_errors(call):
    with pytest.raises(ValueError) as e:
        call()
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("call", WRONG_TYPES.values(), ids=WRONG_TYPES.keys())
def test_wrong_types_are_type_errors(call):
    with pytest.raises(TypeError):
        call()


def test_seed_and_flag_errors_name_the_argument():
    with pytest.raises(ValueError, match=r"seed must be an integer in \[0, 2\*\*64\), got 18446744073709551616"):
        wolfpack.BatchEnv(seed=2**64)
    with pytest.raises(ValueError, match="autoreset must be True or False, got 'no'"):
        wolfpack.BatchEnv(autoreset="no")
    with pytest.raises(ValueError, match=r"threads must be an integer in \[1, 256\], got 100000"):
        wolfpack.BatchEnv(threads=100_000)
    with pytest.raises(ValueError, match="chunk must be None or an integer >= 1"):
        wolfpack.run_episodes(None, 1, chunk=0)
    with pytest.raises(TypeError, match="num_envs must be an integer, got float"):
        wolfpack.BatchEnv(num_envs=2.0)


def test_numpy_integers_and_bools_are_accepted_and_the_largest_seed_works():
    env = wolfpack.BatchEnv(num_envs=np.int64(2), seed=np.uint64(7), autoreset=np.bool_(False), threads=np.int32(1))
    env.reset(seed=np.int64(3))
    env.reset_world(np.int64(1), seed=2**64 - 1)
    assert env.world_state(np.int64(1))["seed"] == 2**64 - 1
    (result,) = wolfpack.run_episodes(None, 1, seed=2**64 - 1, record=np.bool_(False), threads=1, chunk=np.int64(1))
    assert result["seed"] == 2**64 - 1


# --- the command line: --out, and runs that do not finish ------------------------------------


@pytest.mark.parametrize(
    "args",
    [["hunt", "--out", ""], ["hunt", "--out", "  "], ["replay", ""], ["replay", "x", "--out", ""], ["hunt", "--threads", str(MAX_THREADS + 1)], ["bench", "--threads", "100000"]],
)
def test_empty_out_and_too_many_threads_are_usage_errors(tmp_path, args):
    proc = subprocess.run([sys.executable, "-m", "wolfpack", *args], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert proc.returncode == 2
    assert_clean_failure(proc, "--out" if "--out" in args else ("EPISODE_DIR" if args[0] == "replay" else "--threads"))
    assert list(tmp_path.iterdir()) == []


def test_a_finished_run_has_no_marker_and_a_failed_fresh_run_leaves_nothing(cli, tmp_path):
    out = tmp_path / "run"
    assert cli("hunt", "--episodes", "2", "--plots", "0", "--out", out, *SHORT).returncode == 0
    assert sorted(p.name for p in out.iterdir()) == [outputs.MANIFEST_NAME, "episode_000", "episode_001", "index.html", "summary.json", "summary.png"]
    # A spawn that fails while running, into a new nested folder: no folder is left behind.
    assert_clean_failure(cli("hunt", "--episodes", "1", "--out", tmp_path / "a" / "b", "--set", "obstacles.static_polygons=500"), "spawn")
    # ... and into an existing empty folder: it stays, empty.
    (tmp_path / "empty").mkdir()
    assert_clean_failure(cli("hunt", "--episodes", "1", "--out", tmp_path / "empty", "--set", "obstacles.static_polygons=500"), "spawn")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty", "run"]
    assert list((tmp_path / "empty").iterdir()) == []


def test_force_replaces_an_interrupted_run_and_its_marker(cli, tmp_path):
    out = tmp_path / "run"
    (out / "episode_007").mkdir(parents=True)
    (out / logs.INCOMPLETE_NAME).write_text("an earlier interrupted run\n")
    outputs.write_manifest(out, "wolfpack hunt", ["episode_007", logs.INCOMPLETE_NAME])  # what its Ctrl-C leaves
    assert_clean_failure(cli("hunt", "--episodes", "1", "--out", out, *SHORT), "--force")
    assert cli("hunt", "--episodes", "1", "--plots", "0", "--out", out, "--force", *SHORT).returncode == 0
    assert sorted(p.name for p in out.iterdir()) == [outputs.MANIFEST_NAME, "episode_000", "index.html", "summary.json", "summary.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no temporary sibling left


@pytest.fixture(autouse=True)
def _sigint_as_in_a_terminal():
    """The in-process Ctrl-C tests below run the CLI as a terminal runs it, where it installs
    its own SIGINT handler. A test run started in the background has SIGINT ignored, and the
    CLI then leaves Ctrl-C alone on purpose; each test also starts with no Ctrl-C pending."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    CtrlC.pending = False
    yield
    signal.signal(signal.SIGINT, previous)
    CtrlC.pending = False


def _interrupt_inside_savez(monkeypatch, after: int):
    """Makes the (after+1)-th trajectory write fail the way Ctrl-C would: KeyboardInterrupt
    from inside np.savez_compressed, with part of the file written."""
    real = np.savez_compressed
    calls = {"n": 0}

    def savez(f, **arrays):
        calls["n"] += 1
        if calls["n"] > after:
            f.write(b"PK\x03\x04 half a zip")
            raise KeyboardInterrupt
        return real(f, **arrays)

    monkeypatch.setattr(logs.np, "savez_compressed", savez)


def test_an_interrupted_write_leaves_the_old_file_and_no_temporary(monkeypatch, tmp_path):
    path = tmp_path / "trajectory.npz"
    logs.write_trajectory(path, {"a": np.zeros(3)})
    logs.write_json_atomic(tmp_path / "summary.json", {"a": 1})
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    _interrupt_inside_savez(monkeypatch, after=0)
    with pytest.raises(KeyboardInterrupt):
        logs.write_trajectory(path, {"a": np.ones(3)})

    def dump(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(logs.json, "dump", dump)
    with pytest.raises(KeyboardInterrupt):
        logs.write_json_atomic(tmp_path / "summary.json", {"a": 2})
    with pytest.raises(KeyboardInterrupt):
        with logs.atomic_path(tmp_path / "trajectory.png", keep_suffix=True) as tmp:
            assert tmp.name == ".trajectory.tmp.png"
            tmp.write_bytes(b"half a png")
            raise KeyboardInterrupt
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def _run_main(argv, capsys) -> tuple[int, str]:
    with pytest.raises(SystemExit) as done:
        cli.main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert captured.out == ""
    return done.value.code, captured.err


def _assert_every_file_complete(folder: Path) -> None:
    assert not [p for p in folder.rglob(".*") if p.name != outputs.MANIFEST_NAME], "temporary files left"
    for episode in folder.glob("episode_*"):
        with np.load(episode / "trajectory.npz", allow_pickle=False) as data:
            assert "wolves" in data.files and np.isfinite(data["wolves"]).all()


def test_ctrl_c_inside_a_trajectory_write_leaves_only_complete_files_and_the_marker(monkeypatch, capsys, tmp_path):
    out = tmp_path / "run"
    _interrupt_inside_savez(monkeypatch, after=2)
    status, err = _run_main(["hunt", "--episodes", "5", "--plots", "0", "--out", out, "--set", "world.max_steps=30"], capsys)
    assert status == 130
    assert err.count("\n") == 1 and err.startswith("wolfpack: interrupted; ") and "INCOMPLETE" in err and "2 of 5 episodes" in err, err
    assert sorted(p.name for p in out.iterdir()) == [outputs.MANIFEST_NAME, "INCOMPLETE", "episode_000", "episode_001"]
    _assert_every_file_complete(out)
    marker = (out / "INCOMPLETE").read_text()
    assert "interrupted" in marker and "wolfpack hunt --episodes 5" in marker


def test_ctrl_c_with_force_leaves_the_earlier_run_intact(monkeypatch, capsys, tmp_path):
    out = tmp_path / "run"
    cli.main(["hunt", "--episodes", "2", "--plots", "1", "--out", str(out), "--set", "world.max_steps=30", "--json"])
    capsys.readouterr()
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    _interrupt_inside_savez(monkeypatch, after=1)
    status, err = _run_main(["hunt", "--episodes", "3", "--seed", "4", "--plots", "0", "--out", out, "--force", "--set", "world.max_steps=30"], capsys)
    assert status == 130 and err == f"wolfpack: interrupted; the earlier run in {out} is intact (this run's files were removed)\n"
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_a_ctrl_c_that_python_swallows_in_a_finalizer_still_stops_the_run(monkeypatch, capsys, tmp_path):
    """Python reports a KeyboardInterrupt raised inside a finalizer or weakref callback
    (matplotlib runs many during garbage collection) as "Exception ignored" and goes on: the
    command line must record it and stop at the next episode, printing one line."""

    class Finalizer:
        def __del__(self):
            raise KeyboardInterrupt

    real = logs.write_trajectory
    calls = {"n": 0}

    def write(path, arrays):
        real(path, arrays)
        calls["n"] += 1
        if calls["n"] == 2:
            Finalizer()  # dropped at once: its KeyboardInterrupt is "ignored"

    monkeypatch.setattr(logs, "write_trajectory", write)
    status, err = _run_main(["hunt", "--episodes", "6", "--plots", "0", "--out", tmp_path / "run", "--set", "world.max_steps=30"], capsys)
    assert status == 130 and err.count("\n") == 1 and "Exception ignored" not in err and "2 of 6 episodes" in err, err
    assert not (tmp_path / "run" / "summary.json").exists()


def test_a_ctrl_c_that_an_extension_turns_into_an_import_error_still_stops_the_run_cleanly(monkeypatch, capsys, tmp_path):
    """A KeyboardInterrupt raised while a C extension initialises reaches Python as
    ``ImportError: initialization failed`` (seen in CI: Ctrl-C while the first savefig imported
    matplotlib's Agg backend). It must still end the run as a Ctrl-C: status 130, one line, the
    finished episodes kept, not a traceback and not the run's files removed."""
    from wolfpack import plots

    real = plots.plot_trajectory
    calls = {"n": 0}

    def plot(arrays, path, **kwargs):
        calls["n"] += 1
        if calls["n"] == 2:  # the second episode's first plot
            try:
                CtrlC.handler(signal.SIGINT, None)  # what the signal does
            except KeyboardInterrupt:
                raise ImportError("initialization failed") from None  # what the extension makes of it
        return real(arrays, path, **kwargs)

    monkeypatch.setattr(plots, "plot_trajectory", plot)
    out = tmp_path / "run"
    status, err = _run_main(["hunt", "--episodes", "4", "--plots", "4", "--out", out, "--set", "world.max_steps=30"], capsys)
    assert status == 130 and err.count("\n") == 1 and err.startswith("wolfpack: interrupted; ") and "INCOMPLETE" in err, err
    assert "2 of 4 episodes" in err, err  # episode 1's trajectory was written before its plots
    assert sorted(p.name for p in out.iterdir()) == [outputs.MANIFEST_NAME, "INCOMPLETE", "episode_000", "episode_001"]
    _assert_every_file_complete(out)


def test_an_error_without_a_ctrl_c_still_removes_the_run_and_is_not_called_an_interrupt(monkeypatch, capsys, tmp_path):
    from wolfpack import plots

    def plot(arrays, path, **kwargs):
        raise ImportError("initialization failed")

    monkeypatch.setattr(plots, "plot_trajectory", plot)
    out = tmp_path / "run"
    with pytest.raises(ImportError):
        cli.main(["hunt", "--episodes", "2", "--plots", "1", "--out", str(out), "--set", "world.max_steps=30"])
    assert not out.exists()


# --- replay checks the file ---------------------------------------------------------------------


def _arrays() -> dict:
    return logs.trajectory_arrays(synthetic_result(n=3, m=2, steps=6), _core.default_params())


def _set(key, value):
    def change(a):
        a[key] = value(a) if callable(value) else value

    return change


BAD_TRAJECTORIES = [
    ("wolves [T+1,N,4]", _set("wolves", lambda a: a["wolves"][:, :, :4]), "wolves: expected shape"),
    ("wolves 2-D", _set("wolves", lambda a: a["wolves"][:, 0]), "wolves: expected shape"),
    ("targets rows", _set("targets", lambda a: a["targets"][:-1]), "targets: expected shape"),
    ("energy shape", _set("energy", lambda a: a["energy"][:, :-1]), "energy: expected shape"),
    ("interaction rows", _set("interaction", lambda a: a["interaction"][:-1]), "interaction: expected shape"),
    ("interaction agents", _set("interaction", lambda a: a["interaction"][:, :2, :2]), "interaction: expected shape"),
    ("obstacle_poses rows", _set("obstacle_poses", lambda a: a["obstacle_poses"][1:]), "obstacle_poses: expected shape"),
    ("obstacle_kind K", _set("obstacle_kind", lambda a: a["obstacle_kind"][:1]), "obstacle_kind: expected shape"),
    ("obstacle_radius K", _set("obstacle_radius", lambda a: a["obstacle_radius"][:1]), "obstacle_radius: expected shape"),
    ("obstacle_vertices K", _set("obstacle_vertices", lambda a: a["obstacle_vertices"][:1]), "obstacle_vertices: expected shape"),
    ("target_capture_step M", _set("target_capture_step", np.array([-1])), "target_capture_step: expected shape"),
    ("border shape", _set("border", np.zeros(3)), "border: expected shape"),
    ("wolves strings", _set("wolves", lambda a: a["wolves"].astype(str)), "wolves: must hold numbers"),
    ("energy strings", _set("energy", lambda a: a["energy"].astype(str)), "energy: must hold numbers"),
    ("border bytes", _set("border", np.array([b"a", b"b", b"c", b"d"])), "border: must hold numbers"),
    ("outcome number", _set("outcome", np.array(3)), "outcome: must hold strings"),
    ("wolves all NaN", _set("wolves", lambda a: np.full_like(a["wolves"], np.nan)), "wolves: not finite"),
    ("targets inf", _set("targets", lambda a: np.where(np.arange(5) == 1, np.inf, a["targets"])), "targets: not finite"),
    ("energy NaN", _set("energy", lambda a: a["energy"] * np.nan), "energy: not finite"),
    ("interaction all NaN", _set("interaction", lambda a: np.full(a["interaction"].shape, np.nan)), "interaction: entries are 0 or 1, got nan at index [0, 0, 0]"),
    ("interaction 2", _set("interaction", lambda a: a["interaction"] * 0 + 2), "interaction: entries are 0 or 1, got 2"),
    ("obstacle_poses NaN", _set("obstacle_poses", lambda a: a["obstacle_poses"] * np.nan), "obstacle_poses: not finite"),
    ("border NaN", _set("border", np.array([np.nan, -10, 10, 10])), "border: not finite"),
    ("border order", _set("border", np.array([10.0, -10, -10, 10])), "border: expected x_min < x_max"),
    ("capture_distance NaN", _set("capture_distance", np.array(np.nan)), "capture_distance: not finite"),
    ("ts zero", _set("ts", np.array(0.0)), "ts and capture_distance: must be > 0"),
    ("unknown kind", _set("obstacle_kind", np.array(["moving_circle", "blob"])), "obstacle_kind[1]"),
    ("polygon of 2 vertices", _set("obstacle_vertices", lambda a: np.where(np.arange(5)[None, :, None] >= 2, np.nan, a["obstacle_vertices"])), "obstacle_vertices[1]"),
    ("missing ts", lambda a: a.pop("ts"), "missing ts"),
]


def test_a_good_trajectory_passes_the_check():
    logs.check_trajectory(_arrays())


@pytest.mark.parametrize(("name", "change", "fragment"), BAD_TRAJECTORIES, ids=[b[0] for b in BAD_TRAJECTORIES])
def test_replay_names_what_is_wrong_with_the_arrays(tmp_path, capsys, name, change, fragment):
    arrays = _arrays()
    change(arrays)
    episode = tmp_path / "episode_000"
    episode.mkdir()
    np.savez(episode / "trajectory.npz", **arrays)
    status, err = _run_main(["replay", episode, "--out", tmp_path / "out"], capsys)
    assert status == 2
    assert err.count("\n") == 1 and err.startswith(f"wolfpack: error: {episode / 'trajectory.npz'}: ") and fragment in err, err
    assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())  # no video of NaN


def test_replay_of_string_or_nan_arrays_from_the_command_line(cli, tmp_path):
    for name, value in (("strings", lambda a: a["wolves"].astype(str)), ("nan", lambda a: np.full_like(a["wolves"], np.nan))):
        arrays = _arrays()
        arrays["wolves"] = value(arrays)
        path = tmp_path / f"{name}.npz"
        np.savez(path, **arrays)
        assert_clean_failure(cli("replay", path, "--out", tmp_path / name), "wolves: ")
        assert not (tmp_path / name).exists()


# --- Ctrl-C from the outside ----------------------------------------------------------------------

LATENCY_LIMIT_S = 1.5  # the issue asks for 1 s; headroom for a loaded machine (measured: ~0.05 s)

needs_proc = pytest.mark.skipif(not Path("/proc/self/stat").exists() or os.name != "posix", reason="needs Linux /proc and POSIX signals")


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _interrupt(args, ready, cwd=None, settle: float = 0.3) -> tuple[subprocess.CompletedProcess, float]:
    """Starts ``wolfpack ARGS``, waits until ``ready(pid)`` (at most 60 s), then ``settle``
    seconds more, sends SIGINT and waits for the exit; returns the process and the seconds from
    the signal to the exit (the process is killed if it does not end within 20 s)."""
    proc = popen_interruptible([sys.executable, "-m", "wolfpack", *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=cwd)
    try:
        deadline = time.monotonic() + 60
        while not ready(proc.pid):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "the run never got going"
            time.sleep(0.02)
        time.sleep(settle)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGINT)
        try:
            out, err = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
        return subprocess.CompletedProcess(proc.args, proc.returncode, out, err), time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _busy(pid: int) -> bool:
    """Past start-up (about 0.3 s of CPU): simulating."""
    return _cpu_seconds(pid) > 1.0


def _assert_interrupted(proc, seconds: float, fragment: str = "") -> None:
    print(f"wolfpack {proc.args[3]}{' --out' if '--out' in proc.args else ''}: exit {proc.returncode} {seconds:.3f} s after SIGINT")  # pytest -rP shows it
    assert proc.returncode == 130, (proc.returncode, proc.stderr)
    assert seconds <= LATENCY_LIMIT_S, f"exited {seconds:.2f} s after SIGINT"
    assert proc.stdout == ""
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("wolfpack: interrupted"), proc.stderr
    assert fragment in lines[0], lines[0]


@needs_proc
def test_ctrl_c_stops_a_long_hunt_without_out_at_once():
    proc, seconds = _interrupt(["hunt", "--episodes", "200000", "--seed", "0"], _busy)
    _assert_interrupted(proc, seconds)
    assert proc.stderr == "wolfpack: interrupted\n"


@needs_proc
@pytest.mark.parametrize("settle", [0.0, 0.4])
def test_ctrl_c_stops_a_long_hunt_with_out_at_once_and_leaves_readable_files(tmp_path, settle):
    out = tmp_path / "run"
    proc, seconds = _interrupt(["hunt", "--episodes", "200000", "--seed", "0", "--out", out], lambda pid: (out / "episode_000" / "trajectory.npz").exists(), settle=settle)
    _assert_interrupted(proc, seconds, "incomplete")
    assert "INCOMPLETE" in proc.stderr and "no summary.json" in proc.stderr
    assert (out / "INCOMPLETE").is_file() and not (out / "summary.json").exists()
    assert "interrupted" in (out / "INCOMPLETE").read_text()
    episodes = sorted(out.glob("episode_*"))
    assert episodes and all((e / "trajectory.npz").is_file() for e in episodes)
    _assert_every_file_complete(out)


@needs_proc
def test_ctrl_c_during_a_forced_rerun_keeps_the_earlier_run(cli, tmp_path):
    out = tmp_path / "run"
    assert cli("hunt", "--episodes", "2", "--plots", "0", "--out", out, *SHORT).returncode == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    proc, seconds = _interrupt(["hunt", "--episodes", "200000", "--out", out, "--force"], lambda pid: any(out.glob(f"{outputs.STAGING_PREFIX}*/episode_000")))
    _assert_interrupted(proc, seconds, "is intact")
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


@needs_proc
def test_ctrl_c_stops_bench_and_replay_at_once(tmp_path):
    proc, seconds = _interrupt(["bench", "--episodes", "100000", "--threads", "1"], _busy)
    _assert_interrupted(proc, seconds)
    # A long episode to re-render (synthetic: 3000 steps).
    episode = tmp_path / "episode_000"
    episode.mkdir()
    logs.write_trajectory(episode / "trajectory.npz", logs.trajectory_arrays(synthetic_result(steps=3000), _core.default_params()))
    proc, seconds = _interrupt(["replay", episode, "--no-plots", "--out", tmp_path / "video"], _busy)
    _assert_interrupted(proc, seconds)
    assert not list((tmp_path / "video").iterdir())  # no partial episode.mp4, no temporary file


def _in_forked_child(target, what: str):
    """Runs ``target(queue)`` in a child forked from this process and returns what it put on the
    queue; fails the test when the child hangs (``what`` names the call that hung)."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=target, args=(queue,))
    child.start()
    child.join(60)
    if child.is_alive():
        child.kill()
        pytest.fail(f"{what} hung in a forked child")
    assert child.exitcode == 0
    return queue.get(timeout=5)


def _episodes_in_child(queue) -> None:
    queue.put(len(wolfpack.run_episodes(None, 3, 0, threads=2)))


@pytest.mark.skipif(sys.platform != "linux", reason="fork start method")
def test_threaded_runs_work_in_a_forked_child_after_the_parent_used_its_pool():
    """The core keeps one thread pool per thread count for repeated calls; a child forked
    after the parent started one has none of its threads and must start its own, not hang."""
    assert len(wolfpack.run_episodes(None, 3, 0, threads=2)) == 3
    assert _in_forked_child(_episodes_in_child, "run_episodes") == 3


_FORKED_BATCH = None


def _batch_steps_in_child(queue) -> None:
    env = _FORKED_BATCH
    obs = None
    for _ in range(3):
        obs = env.step(np.zeros((64, 5, 2), np.float32))["obs_wolves"]
    queue.put(obs.shape)


@pytest.mark.skipif(sys.platform != "linux", reason="fork start method")
def test_a_threaded_batch_made_before_a_fork_steps_in_the_child():
    """A batch's crew of threads does not survive a fork: a child stepping a batch its parent
    made (and stepped) must start a crew of its own, not wait forever for the parent's."""
    from wolfpack import BatchEnv

    global _FORKED_BATCH
    _FORKED_BATCH = BatchEnv(num_envs=64, learners="wolves", seed=0, threads=2)
    _FORKED_BATCH.reset(seed=0)
    want = _FORKED_BATCH.step(np.zeros((64, 5, 2), np.float32))["obs_wolves"].shape
    assert _in_forked_child(_batch_steps_in_child, "BatchEnv.step") == want
    # The parent's own crew still works.
    assert _FORKED_BATCH.step(np.zeros((64, 5, 2), np.float32))["obs_wolves"].shape == want
    _FORKED_BATCH = None


def test_a_missing_optional_dependency_names_the_extra(monkeypatch, tmp_path):
    """Without stable-baselines3 (a core install), make_vec_env and loading an SB3 model say
    which extra brings it; without torch, so does loading a native model."""
    import sys

    from wolfpack._optional import require

    monkeypatch.setitem(sys.modules, "stable_baselines3", None)
    with pytest.raises(ImportError, match=r"make_vec_env .* needs stable-baselines3, which is not installed: pip install 'wolfpack\[train\]'"):
        wolfpack.make_vec_env(num_envs=1)
    monkeypatch.setitem(sys.modules, "torch", None)
    with pytest.raises(ImportError, match=r"the model X needs torch, .*wolfpack\[train\]"):
        require("torch", "the model X")


def test_one_env_stepped_from_two_threads_at_once_says_so():
    """A step releases the GIL while the worlds move; a second thread's call on the same env in
    that time is refused with a message a person understands (not pyo3's "Already borrowed"),
    and the env goes on stepping afterwards."""
    import threading

    env = wolfpack.BatchEnv(num_envs=2048, threads=1, seed=0)
    env.reset(seed=0)
    actions = np.zeros((env.num_envs, env.n_wolves, 2), np.float32)
    errors: list[str] = []
    go = threading.Barrier(2)

    def stepper() -> None:
        go.wait()
        try:
            for _ in range(200):
                env.step(actions)
        except RuntimeError as e:
            errors.append(str(e))

    threads = [threading.Thread(target=stepper) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors, "the two threads never overlapped"
    assert all("in use by another thread" in e and "give each thread its own env" in e for e in errors), errors
    assert env.step(actions)["obs_wolves"].shape[0] == env.num_envs
