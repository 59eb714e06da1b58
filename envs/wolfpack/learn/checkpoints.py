"""The files of a training run that outlive it: the resume state (``trainer.pt``, in the run
folder and in each checkpoint), written whole or not at all, read back only as tensors and
plain containers and checked before a run resumes from it; and what a saved model's
configuration records about the software that trained it."""

from __future__ import annotations

import json
import platform
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np
import torch

from wolfpack import _core
from wolfpack.logs import atomic_path
from wolfpack.models import load_tensors

#: The resume state's file name.
TRAINER_FILE = "trainer.pt"


def versions() -> dict:
    """The versions a saved model's configuration records: wolfpack, torch, numpy, Python and
    the machine."""
    return {
        "wolfpack": _core.__version__,
        "torch": str(torch.__version__),
        "numpy": np.__version__,
        "python": sys.version.split()[0],
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
    }


def plain(x: Any) -> Any:
    """``x`` as plain JSON values (tuples become lists), as YAML writes them."""
    return json.loads(json.dumps(x))


def write_atomic(path: Path, writer: Callable[[Path], Any]) -> None:
    """``writer(tmp)`` writes the file under a temporary name beside ``path``, which is then
    renamed to it: a file present is complete (:func:`wolfpack.logs.atomic_path`)."""
    with atomic_path(path) as tmp:
        writer(tmp)


def check_resume_state(path: Path, state: Any, sides: tuple[str, ...]) -> dict:
    """``state`` if it is a resume state of these sides (what :meth:`Trainer._save` writes);
    ValueError naming ``path`` and what is missing otherwise."""
    counters = ("updates", "agent_steps", "resumes")
    if not isinstance(state, dict):
        raise ValueError(f"--resume: {path}: not a resume state of 'wolfpack train'")
    missing = [k for k in ("learners", "generator", *counters, "train_s") if k not in state]
    if not missing:
        missing = [f"learners.{side}" for side in sides if not isinstance(state["learners"], dict) or not isinstance(state["learners"].get(side), dict)]
    if missing:
        raise ValueError(f"--resume: {path}: not a resume state of 'wolfpack train' (it lacks {', '.join(missing)})")
    if not isinstance(state["generator"], torch.Tensor) or not all(isinstance(state[k], int) and not isinstance(state[k], bool) and state[k] >= 0 for k in counters):
        raise ValueError(f"--resume: {path}: not a resume state of 'wolfpack train' (its generator or counters are of another kind)")
    return state


def latest_resume_state(out: Path, sides: tuple[str, ...], device: torch.device) -> tuple[Path, dict]:
    """The resume state of ``out`` with the most agent-steps: its ``trainer.pt`` or a later
    checkpoint's, and where it was read. Tensors and plain containers only (the generator's
    state is a tensor): a file is never run as code, and a truncated or foreign one is a
    ValueError naming it."""
    candidates = [out / TRAINER_FILE, *(out / "checkpoints").glob(f"*/{TRAINER_FILE}")]
    states = [(p, check_resume_state(p, load_tensors(p, map_location=device), sides)) for p in candidates if p.is_file()]
    if not states:
        raise ValueError(f"--resume: {out} holds no {TRAINER_FILE} to resume from (the run never reached its first checkpoint)")
    return max(states, key=lambda ps: ps[1]["agent_steps"])
