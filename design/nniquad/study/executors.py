"""Where Monte Carlo scenarios run: in this process, a local process pool, or a Dask cluster.

Scenarios are simulated one per CasADi call (single-threaded), in batches: the
unit of work of a local :class:`concurrent.futures.ProcessPoolExecutor`
(``spawn`` start method, one process per core, workers ignore Ctrl-C) or of a
Dask distributed cluster (:mod:`nniquad.study.dask_cluster`).  :func:`run_study`
chooses the executor and collects the results.

Faults.  The executors never wait blindly (:mod:`nniquad.study.watch`): every
:data:`~nniquad.study.watch.POLL_S` they collect the finished batches, look at a
:class:`~nniquad.study.watch.StopRequest` and at a stall clock.

* Ctrl-C (SIGINT) -- and SIGTERM, where the caller asks for it (the command
  line does) -- inside :func:`~nniquad.study.watch.catch_interrupts` only *sets*
  the stop request (no ``KeyboardInterrupt`` is raised, so a second signal cannot
  cut the cancelling or the saving short); the pending batches are cancelled and
  the finished ones returned, marked partial (``stopped="interrupted"``, or
  ``"terminated"`` for SIGTERM).
* A worker that dies (a broken local pool; a Dask task whose workers died
  ``allowed-failures`` times), a worker that raises, a lost Dask scheduler, and
  no batch finished for ``stall_timeout_s`` (every worker gone, or hung) raise
  :class:`~nniquad.errors.StudyFailedError` carrying the finished scenarios
  (``.run``).  A Dask worker that dies once is not a fault: the scheduler runs
  its batch again elsewhere.
"""

from __future__ import annotations

import math
import signal
import time
from contextlib import nullcontext
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from nniquad.errors import MonteCarloError, StudyFailedError
from nniquad.resources import usable_cpu_count
from nniquad.scenarios.draws import Scenario
from nniquad.sim.runner import set_batch_threads
from nniquad.study.dask_cluster import CONNECT_TIMEOUT_S, close_client, cluster_threads, connect_scheduler, run_dask
from nniquad.study.runs import ScenarioResult, run_scenarios
from nniquad.study.watch import (
    POLL_S,
    STOP_SIGNALS,
    StopRequest,
    catch_interrupts,
    check_stall_timeout,
    first_line,
    stall_limit,
    stopping_note,
)

__all__ = [
    "StudyRun",
    "StopRequest",
    "STOP_SIGNALS",
    "catch_interrupts",
    "make_batches",
    "auto_batch_size",
    "run_study",
    "connect_scheduler",
    "close_client",
    "cluster_threads",
    "CONNECT_TIMEOUT_S",
    "POLL_S",
]



def auto_batch_size(n: int, workers: int) -> int:
    """About four batches per worker, 1 to 50 scenarios each.

    At ~0.06 s per 20 s scenario, a batch of 50 is ~3 s of work against a
    scheduling cost of a few ms (local pool or Dask).
    """
    return max(1, min(50, math.ceil(n / (4 * max(1, workers)))))


def make_batches(scenarios: Sequence[Scenario], batch_size: int) -> list[list[Scenario]]:
    """Consecutive batches of ``batch_size`` scenarios (the last may be shorter).

    Raises
    ------
    MonteCarloError
        ``batch_size`` is not a positive integer.
    """
    if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
        raise MonteCarloError(f"batch size must be a positive integer, got {batch_size!r}")
    return [list(scenarios[i:i + batch_size]) for i in range(0, len(scenarios), batch_size)]


@dataclass
class StudyRun:
    """Results of :func:`run_study`.

    Attributes
    ----------
    results
        One per finished scenario, sorted by index.
    n_requested
        Number of scenarios asked for.
    partial
        ``True`` when the study stopped early (only finished scenarios are in ``results``).
    elapsed_s
        Wall time [s].
    executor
        ``"in-process"``, ``"local process pool"`` or ``"dask tcp://..."``.
    workers, batch_size
        Worker processes (or Dask threads) and scenarios per batch.
    stopped
        Why it stopped early: ``"interrupted"`` (Ctrl-C, a stop request),
        ``"terminated"`` (SIGTERM, where caught) or the ``kind`` of a
        :class:`~nniquad.errors.StudyFailedError`; ``None`` when it ran to the end.
    reason
        The one-line account of ``stopped``.
    """

    results: list[ScenarioResult]
    n_requested: int
    partial: bool
    elapsed_s: float
    executor: str
    workers: int
    batch_size: int
    stopped: str | None = None
    reason: str | None = None

    @property
    def scenarios_per_s(self) -> float:
        return len(self.results) / self.elapsed_s if self.elapsed_s > 0 else float("nan")


def _ignore_sigint(batch_threads: int | None = None) -> None:
    """Pool initializer: Ctrl-C is the parent's business; the worker's share of the CPUs for its batches."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if batch_threads is not None:

        set_batch_threads(batch_threads)


def run_study(
    scenarios: Sequence[Scenario],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    client: Any = None,
    batch_size: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
    stall_timeout_s: float | None = None,
    stop: StopRequest | None = None,
    notify: Callable[[str], None] | None = None,
) -> StudyRun:
    """Run the scenarios in batches and collect the results, sorted by index.

    Parameters
    ----------
    scenarios
        From :func:`draw_scenarios`.
    workers
        Local worker processes (default: the usable CPUs, :func:`nniquad.resources.usable_cpu_count`); 1 runs in this
        process.  Ignored with a scheduler.
    scheduler
        Address of a running Dask scheduler (``tcp://host:port``).
    client
        An existing ``dask.distributed.Client`` (instead of ``scheduler``).
    batch_size
        Scenarios per batch (default :func:`auto_batch_size`).
    progress
        Called as ``progress(done, total)`` after each finished batch.
    connect_timeout_s
        Time allowed to reach the scheduler.
    stall_timeout_s
        A pool or cluster on which no batch finished for this long has
        stopped making progress [s] (default
        :data:`nniquad.config.MC_STALL_TIMEOUT_S`; ``inf`` waits for ever).
        Until the first batch finishes, the wait is at least
        :data:`nniquad.config.MC_STARTUP_GRACE_S` (workers start up).  Not
        checked in-process, where nothing else could run the batches.
    stop
        Stops the study when set (finished batches are kept).  Default: a new
        one, set by Ctrl-C while the study runs (:func:`catch_interrupts`).
    notify
        Called with a one-line note when something happens that the user
        should know about while waiting (stopping, no worker left).

    Returns
    -------
    StudyRun
        ``partial`` with ``stopped="interrupted"`` when stopped (Ctrl-C,
        ``KeyboardInterrupt``, ``stop``), ``"terminated"`` when ``stop`` was set
        by SIGTERM (``catch_interrupts(signals=STOP_SIGNALS)``); the finished
        batches are kept and the pending ones cancelled.

    Raises
    ------
    MonteCarloError
        Bad options, an unreachable scheduler.
    StudyFailedError
        A fault while the study ran (a worker or the scheduler died, a worker
        raised, a stall, an unexpected error); ``.run`` holds the finished
        scenarios, ``partial``.
    """
    scenarios = list(scenarios)
    total = len(scenarios)
    if total == 0:
        raise MonteCarloError("no scenarios to run")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                                or workers < 1):
        raise MonteCarloError(f"number of workers must be a positive integer, got {workers!r}")
    if batch_size is not None:
        make_batches(scenarios[:1], batch_size)  # validates before any connection is made
    stall_s = check_stall_timeout(stall_timeout_s)
    t0 = time.perf_counter()
    own_client = False
    if client is None and scheduler:
        client = connect_scheduler(scheduler, connect_timeout_s)
        own_client = True
    collected: list[ScenarioResult] = []
    done = 0

    def _add(res: list[ScenarioResult]) -> None:
        nonlocal done
        collected.extend(res)
        done += len(res)
        if progress is not None:
            progress(done, total)

    def _note(text: str) -> None:
        if notify is not None:
            try:
                notify(text)
            except Exception:  # noqa: BLE001 -- a note must not stop the study
                pass

    if client is not None:
        n_workers = max(1, cluster_threads(client))
        executor = f"dask {getattr(client.scheduler, 'address', scheduler)}"
    else:
        n_workers = int(workers or usable_cpu_count())
        executor = "in-process" if n_workers == 1 else "local process pool"
    bs = auto_batch_size(total, n_workers) if batch_size is None else int(batch_size)
    batches = make_batches(scenarios, bs)
    stopped: str | None = None
    fault: StudyFailedError | None = None
    with (catch_interrupts() if stop is None else nullcontext(stop)) as stop_request:
        try:
            if client is not None:
                stopped = run_dask(client, executor[5:], batches, _add, stop_request, stall_s, _note)
            elif n_workers == 1:
                stopped = _run_here(batches, _add, stop_request)
            else:
                stopped = _run_pool(n_workers, batches, _add, stop_request, stall_s, _note)
        except StudyFailedError as exc:
            fault = exc
        except Exception as exc:  # noqa: BLE001 -- a bug: keep what finished, the cause goes with it
            fault = StudyFailedError(f"the study stopped on an unexpected error: {type(exc).__name__}: "
                                     f"{first_line(exc)}", kind="error")
            fault.__cause__ = exc
        finally:
            if own_client:
                close_client(client)
    collected.sort(key=lambda r: r.index)
    if fault is None and stopped is None and len(collected) < total:  # never call a study complete that is not
        fault = StudyFailedError(f"the study ended with {total - len(collected)} of {total} scenarios missing",
                                 kind="error")
    reason: str | None = None
    if fault is not None:
        stopped, reason = fault.kind, fault.reason
    elif stopped is not None and len(collected) < total:
        stopped, reason = stop_request.kind, stop_request.reason
    else:  # stopped after the last batch had finished: nothing is missing
        stopped = None
    run = StudyRun(collected, total, stopped is not None, time.perf_counter() - t0, executor, n_workers, bs,
                   stopped, reason)
    if fault is not None:
        fault.run = run
        raise fault
    return run


def _run_here(batches: list[list[Scenario]], add: Callable[[list[ScenarioResult]], None],
              stop: StopRequest) -> str | None:
    """In this process, one scenario per call: a stop takes effect after the running scenario."""
    try:
        for batch in batches:
            for s in batch:
                if stop.requested:
                    return "interrupted"
                add(run_scenarios([s]))
    except KeyboardInterrupt:  # no handler installed (not the main thread), or raised by the callee
        return "interrupted"
    return None


def _exit_description(exitcode: int | None) -> str:
    if exitcode is None:
        return "still running"
    if exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exit status {exitcode}"


def _run_pool(n_workers: int, batches: list[list[Scenario]], add: Callable[[list[ScenarioResult]], None],
              stop: StopRequest, stall_s: float, note: Callable[[str], None]) -> str | None:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    n_procs = min(n_workers, len(batches))
    # each worker's batches get its share of the usable CPUs: W workers x C threads would take turns
    pool = ProcessPoolExecutor(max_workers=n_procs,
                               mp_context=multiprocessing.get_context("spawn"),
                               initializer=_ignore_sigint, initargs=(max(1, usable_cpu_count() // n_procs),))
    pending: set[Any] = set()
    seen: dict[int, Any] = {}  # every worker process, to say which one died and how
    finished = False

    def take(fut: Any) -> None:
        pending.discard(fut)
        exc = fut.exception()
        if exc is None:
            add(fut.result())
        elif isinstance(exc, BrokenProcessPool):
            if stop.requested:  # Ctrl-C on the terminal also reached a worker still starting up
                return
            # the pool may report the broken pipe before the dead worker is reaped: give it a moment to
            # show its exit code, so the message names it (this is the fault path, never the normal one)
            deadline = time.monotonic() + 2.0
            while time.monotonic() < deadline and not any(p.exitcode not in (None, 0) for p in seen.values()):
                time.sleep(0.02)
            if stop.requested:  # a SIGTERM to the whole process group: the workers went first
                return
            dead = [f"pid {pid}, {_exit_description(p.exitcode)}" for pid, p in seen.items()
                    if p.exitcode not in (None, 0)]
            raise StudyFailedError(f"a local worker process died ({'; '.join(dead) or 'terminated abruptly'})",
                                   kind="worker")
        else:  # run_scenarios turns simulation errors into failures: anything else is a bug
            raise exc

    try:
        pending = {pool.submit(run_scenarios, b) for b in batches}
        last = time.monotonic()
        while pending:
            seen.update(getattr(pool, "_processes", None) or {})
            if stop.requested:
                stopping_note(note)
                return "interrupted"
            ready, _ = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
            for fut in ready:
                take(fut)
                last = time.monotonic()
            if stop.requested:
                continue
            limit = stall_limit(stall_s, len(pending) < len(batches))
            if time.monotonic() - last > limit:
                raise StudyFailedError(
                    f"no batch finished in {limit:g} s on {min(n_workers, len(batches))} local worker "
                    f"process(es): the pool has stopped making progress (a longer stall timeout, "
                    f"--stall-timeout, if one batch takes longer)", kind="stalled")
        if stop.requested:  # the last batches were lost to the stop (workers killed with the parent's group)
            return "interrupted"
        finished = True
        return None
    except KeyboardInterrupt:
        return "interrupted"
    finally:
        for fut in list(pending):  # finished while we were stopping: keep them
            if fut.done() and not fut.cancelled() and fut.exception() is None:
                pending.discard(fut)
                add(fut.result())
        if finished:
            pool.shutdown(wait=True, cancel_futures=True)
        else:
            _stop_pool(pool, seen)


#: How long, in all, stopping a pool waits for its SIGKILLed workers to exit (s).
_KILL_WAIT_S = 10.0


def _stop_pool(pool: Any, seen: dict[int, Any]) -> None:
    """Cancel what is queued and end the running batches now (their results would be discarded)."""
    procs = list({**seen, **(getattr(pool, "_processes", None) or {})}.values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        try:
            proc.terminate()
        except Exception:  # noqa: BLE001
            pass
    deadline = time.monotonic() + 3.0
    for proc in procs:
        proc.join(timeout=max(0.0, deadline - time.monotonic()))
    for proc in procs:  # a stopped (SIGSTOP) or hung process ignores SIGTERM
        if proc.is_alive():
            try:
                proc.kill()
            except Exception:  # noqa: BLE001
                pass
    # SIGKILL cannot be ignored, but the exit is not immediate: a worker's sentinel becomes ready when its files
    # close, a moment before the process can be reaped, so join() may return with the worker still alive. Poll
    # until each is reaped (bounded), so that no stopped or dying worker outlives the study.
    deadline = time.monotonic() + _KILL_WAIT_S
    for proc in procs:
        try:
            while proc.is_alive() and time.monotonic() < deadline:
                proc.join(timeout=0.05)
                time.sleep(0.005)
        except Exception:  # noqa: BLE001
            pass


