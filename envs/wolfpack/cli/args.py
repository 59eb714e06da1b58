"""What every command of the ``wolfpack`` command line shares: its name, its exit statuses, the
argument parser whose usage errors are one line, and the argument types."""

from __future__ import annotations

import argparse
from typing import Callable

PROG = "wolfpack"
EXIT_INPUT, EXIT_INTERNAL, EXIT_IO, EXIT_INTERRUPTED = 2, 3, 1, 130


class Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line on stderr (like every other error here)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_INPUT, f"{PROG}: error: {self.prog.removeprefix(PROG).strip() or 'usage'}: {message} (see --help)\n")


def int_at_least(lo: int, hi: int | None = None) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"must be >= {lo}, got {value}")
        if hi is not None and value > hi:
            raise argparse.ArgumentTypeError(f"must be <= {hi}, got {value}")
        return value

    return parse


def _positive(text: str, what: str) -> float:
    """``text`` as a finite number > 0; the errors call it ``what``."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"must be {what} > 0, got {text!r}")
    return value


def positive_minutes(text: str) -> float:
    """A time limit in minutes: a finite number > 0."""
    return _positive(text, "a number of minutes")


def positive_number(text: str) -> float:
    """A finite number > 0."""
    return _positive(text, "a number")


def folder(text: str) -> str:
    """A path argument that must name something: ``--out ''`` is an error, not "no --out"."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; name a folder")
    return text


def count_or_all(text: str) -> int | str:
    """``--trajectories``: an integer >= 0 or ``all``."""
    if text == "all":
        return "all"
    try:
        return int_at_least(0)(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0 or 'all', got {text!r}") from None


def one_line(err: BaseException) -> str:
    return " ".join(str(err).split()) or type(err).__name__
