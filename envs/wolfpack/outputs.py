"""``--out DIR`` and ``--force``: one meaning for every command that writes a folder
(``wolfpack hunt``, ``wolfpack dataset``, ``wolfpack benchmark``).

- A new or empty DIR: the command writes its outputs there.
- DIR holding files: refused, unless ``--force``. With ``--force`` DIR may hold only what an
  earlier run of the same command wrote there, which it recognises by the manifest that run
  left (:data:`MANIFEST_NAME`, a small JSON file listing the files and folders it wrote). The
  new outputs are written into a staging folder inside DIR (:data:`STAGING_PREFIX`; inside, so
  that ``--out .`` works and the final renames never cross a file system) and, once complete,
  replace the earlier run's outputs, and nothing else. A folder holding anything its manifest
  does not list (a user's notes, another command's outputs, a folder written before manifests
  existed) is refused with one line naming some of it: ``--force`` never deletes a file the
  command did not write.
- A run that fails or is interrupted removes its staging folder, so the earlier run stays as
  it was.

The manifest is rewritten before the swap to list the earlier and the new outputs together, so
a swap cut short (a power cut) leaves a folder that the next ``--force`` still accepts.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

#: The manifest a command leaves in DIR: ``{"command": "wolfpack hunt", "outputs": [names]}``.
MANIFEST_NAME = ".wolfpack-outputs.json"
#: The prefix of the staging folder inside DIR (a leftover of a killed run counts as the
#: command's own and is removed by the next ``--force``).
STAGING_PREFIX = ".wolfpack-new-"
_MANIFEST_FILES = (MANIFEST_NAME, f"{MANIFEST_NAME}.tmp")


def read_manifest(folder: str | Path) -> dict[str, Any] | None:
    """The manifest in ``folder`` as ``{"command": str, "outputs": [names]}``; None when there
    is none or it is not one (then nothing in ``folder`` counts as a command's own)."""
    try:
        data = json.loads((Path(folder) / MANIFEST_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or not isinstance(data.get("command"), str) or not isinstance(data.get("outputs"), list):
        return None
    if not all(isinstance(name, str) and name and "/" not in name and name not in (".", "..") for name in data["outputs"]):
        return None
    return data


def write_manifest(folder: Path, command: str, names: list[str]) -> None:
    """Writes the manifest (under a temporary name, then renamed: it is never half written)."""
    tmp = folder / f"{MANIFEST_NAME}.tmp"
    text = json.dumps({"command": command, "outputs": sorted(names), "about": "what this command wrote here; its --force replaces these and nothing else"}, indent=1)
    tmp.write_text(text + "\n", encoding="utf-8")
    os.replace(tmp, folder / MANIFEST_NAME)


def _entries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def _listing(names: list[str], folder: Path) -> str:
    shown = [f"{n}/" if (folder / n).is_dir() else n for n in names[:3]]
    return ", ".join(shown) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)


class Outputs:
    """Where a command writes ``--out DIR`` (see the module docstring).

    Constructing it checks DIR and writes nothing: a ValueError naming DIR when it is a file,
    holds files without ``force``, or holds files the command did not write. :meth:`start`
    creates the folder to write into (:attr:`work`), :meth:`commit` makes what is there DIR's
    outputs, :meth:`discard` removes it.

    Args:
        out: DIR.
        command: the command's name (``"wolfpack hunt"``), recorded in the manifest.
        force: replace an earlier run of the same command.
        in_place: write into a new or empty DIR directly (``wolfpack hunt``, whose Ctrl-C leaves
            the episodes finished so far); otherwise the outputs are always staged and moved in
            by :meth:`commit`, so a failure leaves nothing.
        option: the option's name in messages.
    """

    def __init__(self, out: str | Path, command: str, force: bool, *, in_place: bool = False, option: str = "--out") -> None:
        self.out, self.command, self.in_place = Path(out), command, in_place
        out = self.out
        if out.exists() and not out.is_dir():
            raise ValueError(f"{option} {out}: exists and is not a directory")
        present = _entries(out) if out.is_dir() else []
        self.replacing = bool(present)
        #: The names in DIR that the earlier run wrote (and a killed run's staging folders).
        self.earlier: list[str] = []
        if present:
            if not force:
                raise ValueError(f"{option} {out}: not a new or empty folder; choose another, or add --force to replace what an earlier '{command}' wrote there")
            self.earlier = self._own(present, option)
        self.made: list[Path] = []  # folders start() creates, deepest first
        parent = out
        while not parent.exists():
            self.made.append(parent)
            parent = parent.parent
        self.work: Path | None = None
        self.committed = False

    def _own(self, present: list[str], option: str) -> list[str]:
        """The names of ``present`` that an earlier run of this command wrote; ValueError when
        anything else is there."""
        manifest = read_manifest(self.out)
        theirs = [n for n in present if n not in _MANIFEST_FILES and not n.startswith(STAGING_PREFIX)]
        if manifest is not None and manifest["command"] != self.command:
            raise ValueError(f"{option} {self.out}: holds the outputs of '{manifest['command']}', not of '{self.command}'; --force replaces only this command's own outputs: choose another folder")
        listed = set(manifest["outputs"]) if manifest is not None else set()
        foreign = [n for n in theirs if n not in listed]
        if foreign:
            raise ValueError(
                f"{option} {self.out}: holds files that '{self.command}' did not write ({_listing(foreign, self.out)}); "
                f"--force replaces only the command's own outputs (listed in {MANIFEST_NAME}): move those files, or choose another folder"
            )
        return [n for n in present if n not in _MANIFEST_FILES]

    def start(self) -> Path:
        """Creates DIR (and its parents) and the folder to write into, :attr:`work`."""
        self.out.mkdir(parents=True, exist_ok=True)
        if self.in_place and not self.replacing:
            self.work = self.out
        else:
            self.work = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=self.out))
        return self.work

    def record(self) -> None:
        """In place (a new or empty DIR): lists everything now in DIR as the command's own (it
        was empty when the run started), so that a later ``--force`` may replace it."""
        write_manifest(self.out, self.command, [n for n in _entries(self.out) if n not in _MANIFEST_FILES])

    def commit(self, last: str | None = None) -> None:
        """Makes what :attr:`work` holds DIR's outputs: the earlier run's outputs go (``last``
        first), the new ones move in (``last`` last), and the manifest lists them. Callers
        hold Ctrl-C back meanwhile."""
        assert self.work is not None, "start() first"
        if self.work == self.out:
            self.record()
        else:
            new = _entries(self.work)
            write_manifest(self.out, self.command, sorted(set(self.earlier) | set(new)))
            for name in sorted(self.earlier, key=lambda n: n != last):
                _remove(self.out / name)
            for name in sorted(new, key=lambda n: n == last):
                os.replace(self.work / name, self.out / name)
            write_manifest(self.out, self.command, new)
            self.work.rmdir()
        self.committed = True

    def discard(self) -> None:
        """The run failed or was interrupted: removes the staging folder (an earlier run in DIR
        is untouched); into a new DIR, also the manifest and the folders :meth:`start` made, if
        nothing else is there. In place, the caller removes its own files first."""
        if self.committed or self.work is None:
            return
        if self.work != self.out:
            shutil.rmtree(self.work, ignore_errors=True)
        if not self.replacing:
            (self.out / MANIFEST_NAME).unlink(missing_ok=True)
            for folder in self.made:
                try:
                    folder.rmdir()
                except OSError:
                    break  # someone put a file there meanwhile: leave it
