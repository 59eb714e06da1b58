"""The ``wolfpack`` command's entry point: the parser of every subcommand, and one line and an
exit status for every failure (the table in :mod:`wolfpack.cli`)."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from typing import Sequence

from wolfpack import _core
from wolfpack.cli import bench, benchmark, dataset, exploit, hunt, league, replay, train, view
from wolfpack.cli.args import EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_IO, PROG, Parser, one_line
from wolfpack.interrupt import ctrl_c_handled

#: In the order ``wolfpack --help`` lists them.
COMMANDS = (hunt, replay, view, bench, train, benchmark, exploit, league, dataset)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog=PROG,
        description="wolfpack: multi-agent pursuit-evasion (wolf-pack hunting) with a Rust core.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="run 'wolfpack hunt --help', 'wolfpack replay --help', 'wolfpack bench --help', 'wolfpack train --help', 'wolfpack benchmark --help', 'wolfpack exploit --help', 'wolfpack league --help', 'wolfpack dataset --help' or 'wolfpack view --help' for details.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {_core.__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="{hunt,replay,view,bench,train,benchmark,exploit,league,dataset}", parser_class=Parser)
    for command in COMMANDS:
        command.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of the ``wolfpack`` script; exits with 0 on success. Every failure, Ctrl-C
    included, is one line on stderr and a status (the table in :mod:`wolfpack.cli`)."""
    entry = argv is None  # the process's own command line: it ends here
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        with ctrl_c_handled():
            parser = build_parser()
            if not argv:  # a bare `wolfpack`: what it can do, not an error about what is missing
                parser.print_help()
                return
            args = parser.parse_args(argv)
            args.func(args, argv)
    except ValueError as e:
        sys.exit(_fail(EXIT_INPUT, f"error: {one_line(e)}"))
    except RuntimeError as e:
        message = one_line(e)
        sys.exit(_fail(EXIT_INTERNAL, message if message.startswith("internal error") else f"internal error: {message}"))
    except OSError as e:
        where = f"{e.filename}: " if e.filename else ""
        sys.exit(_fail(EXIT_IO, f"error: {where}{e.strerror or one_line(e)}"))
    except KeyboardInterrupt as e:
        status = _fail(EXIT_INTERRUPTED, f"interrupted{getattr(e, 'detail', '')}")
        if entry and threading.current_thread() is threading.main_thread():
            # The process ends here, at once: a second Ctrl-C must not add a traceback to the
            # line, and every file is closed already, so skip the interpreter's teardown
            # (tearing down matplotlib alone takes a few tenths of a second).
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            for stream in (sys.stdout, sys.stderr):
                try:
                    stream.flush()
                except (OSError, ValueError):
                    pass
            os._exit(status)
        sys.exit(status)


def _fail(status: int, message: str) -> int:
    sys.stderr.write(f"{PROG}: {message}\n")
    return status


def _fail(status: int, message: str) -> int:
    sys.stderr.write(f"{PROG}: {message}\n")
    return status
