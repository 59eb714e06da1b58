"""``--out DIR --force`` means one thing for every command (:mod:`wolfpack.outputs`): it
replaces only what the command itself wrote there, recognised by the manifest it leaves; a
folder holding other files is refused in one line and nothing in it is touched."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import SHORT
from wolfpack import outputs
from wolfpack.outputs import MANIFEST_NAME, STAGING_PREFIX, Outputs

ROOT = Path(__file__).resolve().parents[1]


def wolfpack(*args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "wolfpack", *map(str, args)], capture_output=True, text=True, cwd=cwd or ROOT, timeout=300)


def files(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def refused(run: subprocess.CompletedProcess, fragment: str) -> None:
    assert run.returncode == 2, (run.returncode, run.stderr)
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("wolfpack: error: ") and fragment in lines[0], run.stderr
    assert "Traceback" not in run.stderr and run.stdout == ""


HUNT = ("hunt", "--episodes", "2", "--plots", "0", *SHORT)
DATASET = ("dataset", "--task", "hunt-v1", "--policy", "bvc", "--episodes", "1")
BENCHMARK = ("benchmark", "--wolves", "bvc", "--tasks", "hunt-v1", "--episodes", "1")


@pytest.mark.parametrize("command", [HUNT, DATASET, BENCHMARK], ids=["hunt", "dataset", "benchmark"])
def test_force_replaces_the_commands_own_outputs_and_refuses_a_folder_with_other_files(command, tmp_path):
    out = tmp_path / "out"
    first = wolfpack(*command, "--out", out)
    assert first.returncode == 0, first.stderr
    manifest = json.loads((out / MANIFEST_NAME).read_text())
    assert manifest["command"] == f"wolfpack {command[0]}" and sorted(manifest["outputs"]) == sorted(p.name for p in out.iterdir() if p.name != MANIFEST_NAME)
    # Without --force an occupied folder is refused, whoever wrote it.
    refused(wolfpack(*command, "--out", out), "--force")
    # A user's file beside the outputs: --force refuses the folder and touches nothing.
    (out / "notes.txt").write_text("mine")
    before = files(out)
    refused(wolfpack(*command, "--out", out, "--force"), "notes.txt")
    assert files(out) == before
    # Without it, --force replaces the earlier outputs, and leaves no staging folder.
    (out / "notes.txt").unlink()
    again = wolfpack(*command, "--out", out, "--force")
    assert again.returncode == 0, again.stderr
    assert sorted(p.name for p in out.iterdir()) == sorted([*json.loads((out / MANIFEST_NAME).read_text())["outputs"], MANIFEST_NAME])
    assert not list(out.glob(f"{STAGING_PREFIX}*")) and sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_force_refuses_a_folder_another_command_or_no_command_wrote(tmp_path):
    data = tmp_path / "data"
    assert wolfpack(*DATASET, "--out", data).returncode == 0
    before = files(data)
    refused(wolfpack(*HUNT, "--out", data, "--force"), "outputs of 'wolfpack dataset', not of 'wolfpack hunt'")
    refused(wolfpack(*BENCHMARK, "--out", data, "--force"), "outputs of 'wolfpack dataset'")
    assert files(data) == before
    # A folder of the user's own (no manifest): --force deletes none of it.
    mine = tmp_path / "mine"
    (mine / "sub").mkdir(parents=True)
    (mine / "notes.txt").write_text("mine")
    (mine / "sub" / "more.txt").write_text("mine too")
    for command in (HUNT, DATASET, BENCHMARK):
        refused(wolfpack(*command, "--out", mine, "--force"), "did not write (notes.txt, sub/)")
    assert files(mine) == {"notes.txt": b"mine", "sub/more.txt": b"mine too"}


def test_dataset_out_dot_force_replaces_its_dataset_in_the_current_folder(tmp_path):
    """``--out .`` names the current folder: replaced in place, never renamed away."""
    first = wolfpack(*DATASET, "--out", ".", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    again = wolfpack(*DATASET, "--seed", "7", "--out", ".", "--force", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert json.loads((tmp_path / "dataset.json").read_text())["seed"] == 7
    (tmp_path / "notes.txt").write_text("mine")
    run = wolfpack(*DATASET, "--out", ".", "--force", cwd=tmp_path)
    refused(run, "notes.txt")
    assert "PosixPath" not in run.stderr and (tmp_path / "notes.txt").read_text() == "mine"


def test_an_interrupted_hunt_is_the_commands_own_and_force_replaces_it(tmp_path):
    """A hunt cut short leaves its manifest with its episodes and marker: --force may replace
    them. A failure of the forced run leaves them as they were."""
    out = tmp_path / "run"
    out.mkdir()
    run = Outputs(out, "wolfpack hunt", force=False, in_place=True)
    (run.start() / "episode_000").mkdir()
    (out / "INCOMPLETE").write_text("interrupted\n")
    run.record()
    before = files(out)
    failed = wolfpack(*HUNT, "--out", out, "--force", "--set", "obstacles.static_polygons=500")
    refused(failed, "spawn")
    assert files(out) == before
    assert wolfpack(*HUNT, "--out", out, "--force").returncode == 0
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME, "episode_000", "episode_001", "index.html", "summary.json", "summary.png"]


def test_the_helper_checks_before_writing_and_stages_inside_the_folder(tmp_path):
    out = tmp_path / "a" / "b"
    fresh = Outputs(out, "wolfpack x", force=False)
    assert not (tmp_path / "a").exists()  # constructing it writes nothing
    work = fresh.start()
    assert work.parent == out and work.name.startswith(STAGING_PREFIX)
    (work / "result.txt").write_text("1")
    fresh.commit(last="result.txt")
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME, "result.txt"]
    # A killed run's staging folder is the command's own: the next --force removes it.
    (out / f"{STAGING_PREFIX}left").mkdir()
    again = Outputs(out, "wolfpack x", force=True)
    (again.start() / "other.txt").write_text("2")
    again.commit()
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME, "other.txt"]
    assert outputs.read_manifest(out)["outputs"] == ["other.txt"]
    # A failed run into a new folder leaves nothing, not even the folders it made.
    gone = Outputs(tmp_path / "c" / "d", "wolfpack x", force=False)
    (gone.start() / "half.txt").write_text("")
    gone.discard()
    assert not (tmp_path / "c").exists()
    with pytest.raises(ValueError, match="exists and is not a directory"):
        Outputs(out / "other.txt", "wolfpack x", force=True)
    (out / MANIFEST_NAME).write_text("[garbled")
    with pytest.raises(ValueError, match=r"did not write \(other.txt\)"):
        Outputs(out, "wolfpack x", force=True)
