"""One progress mechanism for every long run (command line, report, notebooks), built on tqdm.

A :class:`Progress` shows one job on stderr: on a terminal a tqdm bar, elsewhere
(CI logs, pipes) a plain line at most every ``every_s`` seconds, so logs stay
readable.  Library functions report progress through a plain callback, and
the callback conventions of the jobs are adapters of the same object:

``progress(fraction, message="")``
    the general form (``fraction`` in [0, 1], or ``None`` when only the message changed);
``progress.fraction(f)``
    a simulation's completed fraction (:func:`nniquad.sim.simulate`);
``progress.message(text)``
    a status line (:func:`nniquad.tune`, :func:`nniquad.certify`);
``progress.steps(total)``
    a callback announcing each of a known number of steps (:func:`nniquad.certify`);
``progress.count(done, total)``
    finished units of work (:func:`nniquad.montecarlo`);
``progress.stage(stage, fraction, detail="")``
    a stage of a pipeline (:func:`nniquad.report`).

Every report is also a checkpoint of the command line's SIGTERM request
(:func:`nniquad.termination.raise_if_terminated`): a request that a C
extension swallowed is raised again here, at the next report.
"""

from __future__ import annotations

import sys
import time
from typing import IO, Callable, Optional

from nniquad.termination import raise_if_terminated

__all__ = ["Progress", "ProgressCallback", "silent"]

#: Signature of the callback every long-running library function accepts.
ProgressCallback = Callable[..., None]


def silent(fraction: Optional[float] = None, message: str = "") -> None:
    """A progress callback that shows nothing."""


class Progress:
    """Progress on stderr for one labelled job.

    Parameters
    ----------
    label
        What is running, e.g. ``"tune"`` or ``"montecarlo"``.
    stream
        Where to write (default ``sys.stderr``).
    every_s
        Minimum time between plain lines when the stream is not a terminal [s].
    enabled
        ``False`` shows nothing; ``None`` (default) shows progress.

    Examples
    --------
    >>> p = Progress("simulate", enabled=False)
    >>> p(0.5, "half way")
    >>> p.close()
    """

    def __init__(self, label: str, stream: IO[str] | None = None, every_s: float = 5.0,
                 enabled: bool | None = None) -> None:
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.every_s = every_s
        self.enabled = enabled is not False
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()
        self._last = -float("inf")
        self._fraction = 0.0
        self._message = ""
        self._bar = None
        if self.enabled and self.tty:
            from tqdm import tqdm

            self._bar = tqdm(total=1000, desc=label, file=self.stream, leave=True, dynamic_ncols=True,
                             bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}] {postfix}")

    @property
    def elapsed_s(self) -> float:
        """Seconds since the job started."""
        return time.perf_counter() - self.t0

    def __call__(self, fraction: Optional[float] = None, message: str = "") -> None:
        """Report progress: the completed ``fraction`` (or ``None``) and a short status ``message``."""
        raise_if_terminated()
        if not self.enabled:
            return
        changed_message = bool(message) and message != self._message
        if fraction is not None:
            self._fraction = min(max(float(fraction), 0.0), 1.0)
        if message:
            self._message = message
        if self._bar is not None:
            self._bar.n = int(round(1000 * self._fraction))
            self._bar.set_postfix_str(self._message, refresh=False)
            self._bar.refresh()
            return
        now = self.elapsed_s
        if now - self._last >= self.every_s or (changed_message and now - self._last >= 1.0) or self._fraction >= 1.0:
            self._last = now
            self.stream.write(f"[{self.label} {now:7.1f} s] {100 * self._fraction:3.0f} %  {self._message}\n")
            self.stream.flush()

    def fraction(self, fraction: float) -> None:
        """Callback for a completed fraction in [0, 1].

        Parameters
        ----------
        fraction
            Completed fraction in [0, 1].
        """
        self(fraction)

    def message(self, text: str) -> None:
        """Callback for a status line (no fraction).

        Parameters
        ----------
        text
            One-line status.
        """
        self(None, text)

    def count(self, done: int, total: int) -> None:
        """Callback for ``done`` of ``total`` units of work finished.

        Parameters
        ----------
        done
            Units finished.
        total
            Units in all.
        """
        self(done / max(total, 1), f"{done}/{total}")

    def steps(self, total: int, done: int = 0) -> Callable[[str], None]:
        """Callback for a job of ``total`` known steps, each announced by a status line (:func:`nniquad.certify`).

        Each call starts the next step: its line is printed at once with the fraction of the steps finished
        before it (``done`` of them before the first call), so the percentages rise from step to step; the
        caller reports 100 % when the job is done.

        Parameters
        ----------
        total
            Steps in all.
        done
            Steps finished before the first call (e.g. a tuning run before the certificate's steps).
        """
        count = [done]

        def step(text: str) -> None:
            fraction = min(count[0] / max(total, 1), 1.0)
            count[0] += 1
            self._last = -float("inf")  # a new step is shown at once, whatever the rate limit
            self(fraction, text)

        return step

    def stage(self, stage: str, fraction: float, detail: str = "") -> None:
        """Callback for a pipeline: a new ``stage`` is printed at once, a ``detail`` at the usual rate.

        Parameters
        ----------
        stage
            Name of the current stage.
        fraction
            Completed fraction of the whole pipeline in [0, 1].
        detail
            Status within the stage.
        """
        if stage != getattr(self, "_stage", None):
            self._stage = stage
            self._fraction = min(max(float(fraction), 0.0), 1.0)
            self.note(f"{100 * self._fraction:3.0f} %  {stage}")
        elif detail:
            self(fraction, detail)

    def note(self, message: str) -> None:
        """Print one line now (a stage change), whatever the rate limit.

        Parameters
        ----------
        message
            The line to print.
        """
        raise_if_terminated()
        if not self.enabled:
            return
        line = f"[{self.label} {self.elapsed_s:7.1f} s] {message}"
        if self._bar is not None:
            self._bar.write(line, file=self.stream)
        else:
            self.stream.write(line + "\n")
            self.stream.flush()
        self._message = message
        self._last = self.elapsed_s

    def close(self, message: str = "done") -> None:
        """End the job with a closing line (``"done"``, ``"interrupted"``, ...).

        Parameters
        ----------
        message
            How the job ended.
        """
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        self.stream.write(f"[{self.label}] {message} in {self.elapsed_s:.1f} s\n")
        self.stream.flush()
