"""The ``wolfpack`` command line, one module per command (``wolfpack.cli.hunt``, ``.replay``,
``.view``, ``.bench``, ``.train``, ``.benchmark``, ``.exploit``, ``.league``, ``.dataset``), what
they share in :mod:`wolfpack.cli.args`, and :func:`main`. ``wolfpack --help`` lists them.

Every failure is one line on stderr and an exit status, never a traceback:

====== ==========================================================================================
status cause
====== ==========================================================================================
2      bad input: params, overrides, layouts, an infeasible spawn, arguments —
       ``wolfpack: error: world.ts: must be a finite number > 0, got 0``
1      the file system (``--out`` not writable, disk full)
3      a bug in the core (a panic caught at the binding) — ``wolfpack: internal error ...``
130    interrupted (Ctrl-C)
====== ==========================================================================================

Nothing is printed on stdout and no ``summary.json`` exists unless the run completed; an
interrupted ``hunt --out DIR`` leaves the marker ``DIR/INCOMPLETE`` (see ``wolfpack hunt --help``).
"""

from wolfpack.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
