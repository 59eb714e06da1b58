"""The files of ``wolfpack hunt --out DIR``: :class:`RunWriter` writes them as episodes arrive,
:class:`RunDir` decides where, so that a run that does not finish never passes for one that did
(docs/interface.md, "wolfpack hunt")."""

from __future__ import annotations

import shlex
import shutil
import time
from pathlib import Path
from typing import Sequence

from wolfpack import logs, render
from wolfpack.cli.args import PROG
from wolfpack.interrupt import CtrlC
from wolfpack.outputs import Outputs
from wolfpack.viewer.encode import encode_episode
from wolfpack.viewer.page import page_data, write_page

#: Episodes that `hunt --out DIR` puts in DIR/index.html at most (about 50 KB each in the
#: documented scenario); `wolfpack view DIR --episodes K` writes a page of more.
INDEX_EPISODES = 100
#: Episodes whose trajectory.npz `hunt --out` keeps unless told (--trajectories).
TRAJECTORIES_DEFAULT = 20
#: Bytes of one compressed trajectory.npz of the documented scenario (300 steps, 6 agents,
#: 12 obstacles), for the size estimate of --trajectories all.
TRAJECTORY_BYTES = 80_000


def default_trajectories(plots: int) -> int:
    """Episodes whose trajectory.npz ``hunt --out`` keeps without ``--trajectories``: 20, or the
    plotted episodes when more."""
    return max(TRAJECTORIES_DEFAULT, plots)


class RunWriter:
    """Writes a run's files into ``out`` as episodes arrive (so a long run never holds every
    trajectory in memory); ``out`` is the folder :class:`RunDir` chose. ``out`` is created at the
    first episode, and ``summary.json`` is written last, by :meth:`finish`. Every file is written
    under a temporary name and renamed: a file under its final name is complete."""

    def __init__(self, out: Path, resolved: dict, plots: int, video: bool = False, trajectories: int | None = None, html: bool = True):
        # Imported here: matplotlib is slow to import and only needed with --out.
        from wolfpack import plots as plotting

        self.plotting = plotting
        self.out, self.resolved, self.plots, self.video = out, resolved, plots, video
        self.trajectories = default_trajectories(plots) if trajectories is None else trajectories
        self.count = 0  # episodes finished
        #: The recorded episodes index.html will show, packed as they arrive (~50 KB each).
        self.pages: list[dict] | None = [] if html else None
        (out / logs.SUMMARY_NAME).unlink(missing_ok=True)

    @property
    def recorded(self) -> int:
        """Episodes whose recorded trajectory something here uses (a file or plots)."""
        return max(self.plots, self.trajectories)

    def episode(self, k: int, result: dict) -> None:
        """Writes ``episode_{k:03d}/trajectory.npz`` for k < trajectories and, for k < plots,
        its plots (and video); later episodes only count (:attr:`count`). A folder left without
        its trajectory.npz by an error or Ctrl-C is removed."""
        self.out.mkdir(parents=True, exist_ok=True)
        if k >= self.recorded:
            self.count += 1
            return
        folder = logs.episode_dir(self.out, k)
        folder.mkdir(exist_ok=True)
        arrays = logs.trajectory_arrays(result, self.resolved)
        if self.pages is not None and len(self.pages) < INDEX_EPISODES:
            self.pages.append(encode_episode(arrays, self.resolved, f"episode_{k:03d} (seed {int(result['seed'])})"))
        if k < self.trajectories:
            try:
                logs.write_trajectory(folder / "trajectory.npz", arrays)
            except BaseException:
                shutil.rmtree(folder, ignore_errors=True)
                raise
        self.count += 1
        if k < self.plots:
            for name, plot in (("trajectory.png", self.plotting.plot_trajectory), ("curves.png", self.plotting.plot_curves), ("interaction.png", self.plotting.plot_interaction)):
                CtrlC.check()
                with logs.atomic_path(folder / name, keep_suffix=True) as tmp:
                    plot(arrays, tmp, label=f"episode {k}")
            if self.video:
                with logs.atomic_path(folder / "episode.mp4", keep_suffix=True) as tmp:
                    render.write_video(CtrlC.checked(render.trajectory_frames(arrays, self.resolved)), tmp)
        CtrlC.check()

    def plot_summary(self, summary: dict) -> None:
        with logs.atomic_path(self.out / "summary.png", keep_suffix=True) as tmp:
            self.plotting.plot_summary(summary["episodes_detail"], tmp)

    def write_index(self, summary: dict, title: str = "wolfpack hunt") -> None:
        """``index.html``: the recorded episodes with their outcomes, played in the browser
        (:mod:`wolfpack.viewer`); none when no episode was recorded or with ``--no-html``."""
        if not self.pages:
            return

        pol, w = self.resolved["policies"], self.resolved["world"]
        details = summary.get("episodes_detail") or []
        n = summary.get("episodes", len(details))
        outcomes = [d["outcome"] for d in details]
        counts = ", ".join(f"{outcomes.count(o)} {o}" for o in self.plotting.OUTCOME_COLOURS if o in outcomes)
        seeds = f", seeds {details[0]['seed']}..{details[-1]['seed']}" if details else ""
        shown = f"the first {len(self.pages)} of {n} episodes" if len(self.pages) < n else f"all {n} episodes"
        subtitle = f"{w['wolves']} {pol['wolves']} wolves vs {w['targets']} {pol['targets']} target(s){seeds}: {counts}; showing {shown}"
        write_page(self.out / "index.html", page_data(self.pages, subtitle=subtitle), title)

    def write_summary(self, summary: dict) -> None:
        logs.write_json_atomic(self.out / logs.SUMMARY_NAME, summary)

    def finish(self, summary: dict) -> None:
        self.plot_summary(summary)
        self.write_index(summary)
        self.write_summary(summary)


class RunDir:
    """Where ``hunt --out DIR`` writes, so that a run that does not finish never passes for one
    that did, and never costs an earlier run its files (:class:`wolfpack.outputs.Outputs`, the
    ``--out``/``--force`` rules every command shares).

    - DIR new or empty: the run writes into DIR, starting with the marker file ``INCOMPLETE``
      (:data:`logs.INCOMPLETE_NAME`), removed only once ``summary.json`` is written. Ctrl-C
      leaves the episodes finished so far (every file complete), the marker, and the manifest
      listing them (a later ``--force`` replaces them); any other failure removes what the run
      wrote.
    - DIR holding an earlier run's outputs (``--force``): the run writes into a staging folder
      inside DIR, and only once it has finished do its files replace the earlier run's; a
      failure or Ctrl-C removes the staging folder and leaves DIR as it was. A DIR holding
      files that no ``wolfpack hunt`` wrote is refused.
    """

    def __init__(self, out: Path, force: bool, command: Sequence[str]):
        self.outputs = Outputs(out, f"{PROG} hunt", force, in_place=True)
        self.out, self.command = out, list(command)
        self.replacing = self.outputs.replacing
        self.committed = False
        self.started = time.strftime("%Y-%m-%d %H:%M:%S %z")
        self.work = self.outputs.start()
        self._mark("it is still running, or it stopped before the end (interrupted or failed)")

    def _mark(self, state: str) -> None:
        text = (
            f"This wolfpack hunt run is INCOMPLETE: {state}.\n"
            f"command: {shlex.join(self.command)}\n"
            f"started: {self.started}\n"
            "summary.json is written, and this file removed, only when every episode has finished. "
            "Every trajectory.npz here is complete and readable.\n"
        )
        with logs.atomic_path(self.work / logs.INCOMPLETE_NAME) as tmp:
            tmp.write_text(text, encoding="utf-8")

    def commit(self) -> None:
        """The run has written its summary.json into :attr:`work`: make it DIR's run."""
        (self.work / logs.INCOMPLETE_NAME).unlink()
        self.outputs.commit(last=logs.SUMMARY_NAME)
        self.committed = True

    def discard(self) -> None:
        """The run failed: remove what it wrote (an earlier run in DIR is untouched)."""
        if self.committed:
            return
        if not self.replacing:
            clear_run(self.out)
        self.outputs.discard()

    def interrupted(self, done: int, total: int) -> str:
        """Ctrl-C: leave DIR as :class:`RunDir` promises; returns what to tell the user."""
        if self.committed:
            return f"; the run had finished: {self.out} holds its complete results"
        if self.replacing:
            self.outputs.discard()
            return f"; the earlier run in {self.out} is intact (this run's files were removed)"
        self._mark(f"it was interrupted (Ctrl-C) after {done} of {total} episodes")
        self.outputs.record()
        return f"; {self.out} is incomplete: {done} of {total} episodes written, marker {logs.INCOMPLETE_NAME}, no summary.json"


def clear_run(out: Path) -> None:
    """Deletes what ``wolfpack hunt --out`` writes (summary.json and its temporary,
    summary.png, index.html, the INCOMPLETE marker, episode_NNN/ folders), so that no episode of an earlier
    run sits beside a new run's; anything else in ``out`` is left alone. summary.json goes
    first, so that a run is never left looking complete with files missing."""
    import re

    for name in (logs.SUMMARY_NAME, f".{logs.SUMMARY_NAME}.tmp", "summary.png", ".summary.tmp.png", "index.html", ".index.tmp.html", logs.INCOMPLETE_NAME, f".{logs.INCOMPLETE_NAME}.tmp"):
        (out / name).unlink(missing_ok=True)
    for child in out.iterdir():
        if child.is_dir() and re.fullmatch(r"episode_\d{3,}", child.name):
            shutil.rmtree(child)
