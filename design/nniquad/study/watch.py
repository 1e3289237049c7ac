"""How a running study is watched: its stop request (Ctrl-C, SIGTERM), the poll period and the stall clock.

The executors (:mod:`nniquad.study.executors` for this process and the local
pool, :mod:`nniquad.study.dask_cluster` for a Dask cluster) never wait blindly:
every :data:`POLL_S` they collect the finished batches, look at a
:class:`StopRequest` and compare the time since the last finished batch with
:func:`stall_limit`.
"""

from __future__ import annotations

import os
import signal
import threading
from contextlib import contextmanager
from typing import Any, Callable, Iterable, Iterator

from nniquad.config import MC_STALL_TIMEOUT_S, MC_STARTUP_GRACE_S
from nniquad.errors import MonteCarloError

__all__ = ["STOP_SIGNALS", "StopRequest", "catch_interrupts", "POLL_S", "check_stall_timeout", "stall_limit",
           "stopping_note", "first_line"]

#: How often a running study looks at its batches, its stop request and its stall clock [s].
POLL_S = 0.2


#: The signals :func:`catch_interrupts` turns into a stop request, and the ``stopped`` kind of each.
STOP_SIGNALS: dict[int, str] = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}


class StopRequest:
    """A request to stop a running study, set by a signal (:func:`catch_interrupts`) or by :meth:`set`.

    The executors look at it every :data:`POLL_S` (in-process: between
    scenarios).  Setting it raises nothing, so it cannot interrupt the
    cancelling of the pending batches or the writing of the finished ones.

    Attributes
    ----------
    signals
        Signals received while it was installed (a second Ctrl-C counts, and is otherwise ignored).
    signum
        The signal that first asked to stop (``signal.SIGINT`` or ``signal.SIGTERM``), or ``None``.
    """

    def __init__(self) -> None:
        self.signals = 0
        self.signum: int | None = None
        self._event = threading.Event()

    def set(self, signum: int | None = None) -> None:
        """Ask the study to stop (thread-safe); ``signum``: the signal that asks, if any (the first one is kept)."""
        if self.signum is None and not self._event.is_set():
            self.signum = signum
        self._event.set()

    @property
    def requested(self) -> bool:
        """``True`` once a stop was asked for."""
        return self._event.is_set()

    @property
    def kind(self) -> str:
        """How the study was stopped: ``"terminated"`` (SIGTERM) or ``"interrupted"`` (Ctrl-C, :meth:`set`)."""
        return STOP_SIGNALS.get(self.signum, "interrupted")

    @property
    def reason(self) -> str:
        """The one-line account of :attr:`kind`."""
        if self.signum == signal.SIGTERM:
            return "terminated (SIGTERM)"
        return "interrupted (Ctrl-C)" if self.signum == signal.SIGINT else "interrupted"


@contextmanager
def catch_interrupts(stop: StopRequest | None = None,
                     repeat_message: str = "still saving the finished scenarios, please wait",
                     signals: Iterable[int] = (signal.SIGINT,)) -> Iterator[StopRequest]:
    """Within the block, SIGINT (Ctrl-C) -- and any other of ``signals`` -- sets a :class:`StopRequest` instead
    of raising.

    A second and later signal only prints ``repeat_message`` (with a raw
    write, safe inside a signal handler), so whatever runs in the block --
    cancelling batches, writing the partial file -- runs to its end.  Outside
    the main thread, where Python cannot install signal handlers, nothing is
    installed and ``KeyboardInterrupt`` keeps its usual meaning.  The previous
    handlers are restored at the end of the block.

    SIGTERM is caught only when asked for (``signals=STOP_SIGNALS``, as
    ``nniquad montecarlo`` does, which then saves the finished scenarios and
    exits with status 143): a library call must not turn a request to end the
    process into a partial result the caller's script carries on from.

    Parameters
    ----------
    stop
        The request to set (a new one by default).
    repeat_message
        Shown on stderr for every signal after the first.
    signals
        The signals caught (keys of :data:`STOP_SIGNALS`; default SIGINT only).

    Yields
    ------
    StopRequest
    """
    stop = StopRequest() if stop is None else stop
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def on_signal(signum: int, frame: Any) -> None:
        stop.signals += 1
        if stop.requested and repeat_message:
            try:
                os.write(2, f"\n[montecarlo] {repeat_message}\n".encode())
            except OSError:
                pass
        stop.set(signum)

    previous = {signum: signal.signal(signum, on_signal) for signum in dict.fromkeys(signals)}
    try:
        yield stop
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)


def first_line(exc: BaseException, limit: int = 120) -> str:
    """The first line of an exception's message (its type name if it has none), cut to ``limit`` characters."""
    text = str(exc).strip()
    detail = text.splitlines()[0] if text else type(exc).__name__
    return detail if len(detail) <= limit else detail[: limit - 3] + "..."


def check_stall_timeout(value: Any) -> float:
    """The stall timeout [s] of a study (``None``: :data:`nniquad.config.MC_STALL_TIMEOUT_S`); refuses a bad one."""
    if value is None:
        return float(MC_STALL_TIMEOUT_S)
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if isinstance(value, bool) or not v > 0:  # also refuses nan
        raise MonteCarloError(f"stall timeout must be a positive number of seconds, got {value!r}")
    return v


def stall_limit(stall_s: float, any_finished: bool) -> float:
    """How long the pool or cluster may go without finishing a batch (more before the first one)."""
    return stall_s if any_finished else max(stall_s, MC_STARTUP_GRACE_S)


def stopping_note(note: Callable[[str], None]) -> None:
    """Tell the user that the study is stopping and what is kept."""
    note("stopping: cancelling the pending batches, keeping the finished ones "
         "(a second Ctrl-C or SIGTERM is ignored until they are saved)")
