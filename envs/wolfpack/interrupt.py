"""Ctrl-C for long commands: a pending interrupt is raised again at the next safe point, a few
renames are held back from it, and the command line says in one line what an interrupted run left
behind (:class:`Interrupted`). Used by the command line and by the trainer it starts."""

from __future__ import annotations

import signal
import sys
import threading
from contextlib import contextmanager
from typing import Any, Iterator


class CtrlC:
    """Ctrl-C for the command line (installed by :func:`ctrl_c_handled` for a command's duration).

    Python raises KeyboardInterrupt wherever the main thread happens to be, and where that is a
    finalizer or a weakref callback (matplotlib runs many, during garbage collection) the
    exception is printed as "Exception ignored in ..." and lost, and the run goes on. So the
    handler also records the interrupt, a lost KeyboardInterrupt is recorded silently
    (``sys.unraisablehook``), and :meth:`check` raises it again at the next safe point (after
    each episode, each file, each frame). The core's signal check calls the handler too, which
    is what stops a long native call."""

    pending = False

    @classmethod
    def handler(cls, signum: int, frame: Any) -> None:
        cls.pending = True
        raise KeyboardInterrupt

    @classmethod
    def check(cls) -> None:
        if cls.pending:
            raise KeyboardInterrupt

    @classmethod
    def caused(cls, error: BaseException) -> bool:
        """Whether ``error`` is how a Ctrl-C surfaced. A KeyboardInterrupt raised inside a C
        extension's module initialisation reaches us as ``ImportError: initialization failed``
        (pybind11 wraps it; seen when Ctrl-C lands while the first savefig imports
        matplotlib's Agg backend), and other native code may wrap it likewise; any error that
        follows a recorded Ctrl-C is therefore treated as the interrupt."""
        return isinstance(error, KeyboardInterrupt) or (cls.pending and isinstance(error, Exception))

    @classmethod
    def checked(cls, items):
        """``items``, checking for a pending Ctrl-C before each."""
        for item in items:
            cls.check()
            yield item


@contextmanager
def ctrl_c_handled() -> Iterator[None]:
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        yield  # not ours to handle (a thread), or Ctrl-C is ignored on purpose (nohup, cmd &)
        return
    CtrlC.pending = False
    previous = signal.signal(signal.SIGINT, CtrlC.handler)
    previous_hook = sys.unraisablehook

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            CtrlC.pending = True
        else:
            previous_hook(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    except Exception as error:
        if CtrlC.caused(error):
            raise KeyboardInterrupt from error
        raise
    finally:
        CtrlC.pending = False  # handled now; a later command in this process starts afresh
        sys.unraisablehook = previous_hook
        signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)


@contextmanager
def sigint_held(drop: bool = False) -> Iterator[None]:
    """Holds Ctrl-C back for the block (a few renames or deletions that must not stop half
    way); a Ctrl-C that arrived meanwhile is raised when it ends, or with ``drop`` forgotten
    (the cleanup after a first Ctrl-C). Only the main thread can handle signals; elsewhere the
    block runs as it is."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)
    if caught and not drop:
        raise KeyboardInterrupt


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a command that writes files, with what it left there (the one-line message
    the command line prints)."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail
