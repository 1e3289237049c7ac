"""SIGTERM handled like Ctrl-C by the command line: clean-up runs, no traceback, exit status 143.

Python's default for SIGTERM ends the process on the spot: no ``finally``
runs, so a temporary file or a report's build folder stays behind.  Within
:func:`sigterm_as_interrupt` (installed by :func:`nniquad.cli.main.main`) a
SIGTERM raises :class:`~nniquad.errors.Terminated`, a ``KeyboardInterrupt``,
so that it gets every clean-up Ctrl-C gets.

The request is *sticky*.  CasADi checks for signals inside its own loops
(IPOPT iterations, function evaluations) and clears the Python exception it
finds there: it reports a failed solve or a plain ``KeyboardInterrupt``
instead, or nothing at all.  So the command line asks
:func:`termination_requested` whatever way a command ends, and every progress
report of a long run (:mod:`nniquad.progress`) calls
:func:`raise_if_terminated`, which raises the request again if it was lost.
A second SIGTERM is ignored: it cannot cut the clean-up short.

``nniquad montecarlo`` catches SIGTERM itself while its study runs
(:func:`nniquad.study.catch_interrupts`), to save the finished scenarios first.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Any, Iterator

from nniquad.errors import Terminated

__all__ = ["sigterm_as_interrupt", "termination_requested", "raise_if_terminated"]

_state = {"requested": False, "installed": 0}


def termination_requested() -> bool:
    """``True`` once a SIGTERM arrived inside :func:`sigterm_as_interrupt` (until the block ends)."""
    return bool(_state["requested"])


def raise_if_terminated() -> None:
    """Raise :class:`~nniquad.errors.Terminated` if a SIGTERM arrived: a checkpoint for long loops.

    Raises
    ------
    Terminated
        When :func:`termination_requested`.
    """
    if _state["requested"]:
        raise Terminated()


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`~nniquad.errors.Terminated` (once) and is remembered.

    Nothing is installed outside the main thread.  The previous handler is
    restored, and the request forgotten, at the end of the block.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_sigterm(signum: int, frame: Any) -> None:
        if not _state["requested"]:
            _state["requested"] = True
            raise Terminated()

    previous = signal.signal(signal.SIGTERM, on_sigterm)
    _state["installed"] += 1
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)
        _state["installed"] -= 1
        if not _state["installed"]:
            _state["requested"] = False
