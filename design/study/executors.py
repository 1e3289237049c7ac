"""Where Monte Carlo scenarios run: in this process, a local process pool, or a Dask cluster.

Scenarios are simulated one per CasADi call (single-threaded), in batches: the
unit of work of a local :class:`concurrent.futures.ProcessPoolExecutor`
(``spawn`` start method, one process per core, workers ignore Ctrl-C) or of a
Dask distributed cluster (:func:`connect_scheduler`, which fails fast on a
bad or unreachable address).  A scenario holds the GIL while CasADi runs, so
Dask workers should be processes with one thread each.

Faults.  The executors never wait blindly: every :data:`POLL_S` they collect
the finished batches, look at a :class:`StopRequest` and at a stall clock.

* Ctrl-C (SIGINT) -- and SIGTERM, where the caller asks for it (the command
  line does) -- inside :func:`catch_interrupts` only *sets* the stop request
  (no ``KeyboardInterrupt`` is raised, so a second signal cannot cut the
  cancelling or the saving short); the pending batches are cancelled and the
  finished ones returned, marked partial (``stopped="interrupted"``, or
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
import os
import signal
import threading
import time
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

import numpy as np

from nniquad.config import MC_STALL_TIMEOUT_S, MC_STARTUP_GRACE_S
from nniquad.errors import MonteCarloError, StudyFailedError
from nniquad.resources import usable_cpu_count
from nniquad.study.runs import ScenarioResult, run_scenarios
from nniquad.study.scenarios import Scenario

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

#: Time allowed to reach a Dask scheduler [s].
CONNECT_TIMEOUT_S = 5.0
#: How often a running study looks at its batches, its stop request and its stall clock [s].
POLL_S = 0.2
#: Time allowed for one exchange with a Dask cluster during a study (fetch a batch, count workers) [s].
CLUSTER_TIMEOUT_S = 10.0


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


def _ignore_sigint(batch_threads: int | None = None) -> None:
    """Pool initializer: Ctrl-C is the parent's business; the worker's share of the CPUs for its batches."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if batch_threads is not None:
        from nniquad.sim.runner import set_batch_threads

        set_batch_threads(batch_threads)


def _first_line(exc: BaseException, limit: int = 120) -> str:
    text = str(exc).strip()
    detail = text.splitlines()[0] if text else type(exc).__name__
    return detail if len(detail) <= limit else detail[: limit - 3] + "..."


def _probe_scheduler(address: str, timeout_s: float) -> Any:
    """Ask the server at ``address`` for its identity over Dask's own protocol (in a fresh event loop)."""
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import connect

    async def identity() -> Any:
        comm = await connect(address, timeout=timeout_s)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    def probe() -> Any:
        return asyncio.run(asyncio.wait_for(identity(), timeout_s))

    # a thread of its own: works even when the caller already runs an event loop (Jupyter)
    with ThreadPoolExecutor(max_workers=1) as ex:
        return ex.submit(probe).result()


def connect_scheduler(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> Any:
    """A ``dask.distributed.Client`` on the running scheduler at ``address``; fails fast and in one line.

    Three steps, each bounded by ``timeout_s``: the address is parsed
    (``tcp://host:port``, ``host:port`` or ``tls://host:port``); a plain TCP
    connection is opened (a refused connection or an unknown host fails at
    once, where Dask itself would retry until its timeout); the server is
    asked for its identity over Dask's protocol (a port that answers but is
    not a Dask scheduler fails here).  Only then is the client created.

    Parameters
    ----------
    address
        Scheduler address, e.g. ``tcp://10.0.0.5:8786``.
    timeout_s
        Time allowed for each step [s].

    Returns
    -------
    distributed.Client
        Not set as the default client; the caller closes it.

    Raises
    ------
    MonteCarloError
        dask.distributed is not installed, the address is malformed, or the
        scheduler cannot be reached in time.
    """
    import socket

    try:
        from distributed import Client
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:
        raise MonteCarloError("--scheduler needs dask.distributed: pip install 'nniquad[dask]'") from None
    import logging

    for name in ("distributed.comm", "distributed.client", "distributed.core", "distributed.batched"):
        logging.getLogger(name).setLevel(logging.CRITICAL)
    where = f"cannot reach the Dask scheduler at {address}"
    if not isinstance(address, str) or not address.strip():
        raise MonteCarloError(f"scheduler address must look like tcp://host:port, got {address!r}")
    try:
        scheme, loc = parse_address(address.strip(), strict=False)
        host, port = parse_host_port(loc)
    except (TypeError, ValueError) as exc:
        raise MonteCarloError(f"scheduler address must look like tcp://host:port, got {address!r} "
                              f"({_first_line(exc)})") from None
    if scheme not in ("tcp", "tls") or not host:
        raise MonteCarloError(f"scheduler address must look like tcp://host:port, got {address!r}")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except socket.gaierror:
        raise MonteCarloError(f"{where}: unknown host {host!r}") from None
    except (socket.timeout, TimeoutError):
        raise MonteCarloError(f"{where}: no answer within {timeout_s:g} s") from None
    except OSError as exc:
        raise MonteCarloError(f"{where}: {exc.strerror or _first_line(exc)}") from None
    if scheme == "tcp":  # tls needs the caller's security settings: the client checks it below
        try:
            ident = _probe_scheduler(address.strip(), timeout_s)
        except Exception as exc:  # noqa: BLE001 -- timeout, garbage from a non-Dask server, ...
            if isinstance(exc, TimeoutError) or "timed out" in str(exc).lower():
                detail = f"no answer within {timeout_s:g} s"
            else:
                detail = f"the server does not answer as a Dask scheduler ({type(exc).__name__})"
            raise MonteCarloError(f"{where}: {detail}") from None
        if not (isinstance(ident, Mapping) and ident.get("type") == "Scheduler"):
            kind = ident.get("type") if isinstance(ident, Mapping) else type(ident).__name__
            raise MonteCarloError(f"{where}: the server is not a Dask scheduler (it says {kind!r})")
    t0 = time.perf_counter()
    try:
        return Client(address.strip(), timeout=f"{timeout_s:g}s", set_as_default=False)
    except Exception as exc:  # noqa: BLE001 -- OSError, TimeoutError, ...
        detail = _first_line(exc)
        if "timed out" in detail.lower() or time.perf_counter() - t0 >= timeout_s:
            detail = f"no answer within {timeout_s:g} s"
        raise MonteCarloError(f"{where}: {detail}") from None


def close_client(client: Any) -> None:
    """Close a client from :func:`connect_scheduler` quietly (the cluster itself keeps running)."""
    try:
        client.close(timeout=2)
    except Exception:  # noqa: BLE001 -- closing is best effort
        pass


def cluster_threads(client: Any, timeout_s: float | None = None) -> int:
    """Worker threads of the cluster behind ``client`` (0 when no worker has joined yet, or no answer in time)."""
    try:
        kwargs = {} if timeout_s is None else {"callback_timeout": timeout_s}
        return int(sum(client.nthreads(**kwargs).values()))
    except Exception:  # noqa: BLE001
        return 0


def _check_stall_timeout(value: Any) -> float:
    if value is None:
        return float(MC_STALL_TIMEOUT_S)
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if isinstance(value, bool) or not v > 0:  # also refuses nan
        raise MonteCarloError(f"stall timeout must be a positive number of seconds, got {value!r}")
    return v


def _stall_limit(stall_s: float, any_finished: bool) -> float:
    """How long the pool or cluster may go without finishing a batch (more before the first one)."""
    return stall_s if any_finished else max(stall_s, MC_STARTUP_GRACE_S)


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
    stall_s = _check_stall_timeout(stall_timeout_s)
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
                stopped = _run_dask(client, executor[5:], batches, _add, stop_request, stall_s, _note)
            elif n_workers == 1:
                stopped = _run_here(batches, _add, stop_request)
            else:
                stopped = _run_pool(n_workers, batches, _add, stop_request, stall_s, _note)
        except StudyFailedError as exc:
            fault = exc
        except Exception as exc:  # noqa: BLE001 -- a bug: keep what finished, the cause goes with it
            fault = StudyFailedError(f"the study stopped on an unexpected error: {type(exc).__name__}: "
                                     f"{_first_line(exc)}", kind="error")
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


def _stopping_note(note: Callable[[str], None]) -> None:
    note("stopping: cancelling the pending batches, keeping the finished ones "
         "(a second Ctrl-C or SIGTERM is ignored until they are saved)")


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
                _stopping_note(note)
                return "interrupted"
            ready, _ = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
            for fut in ready:
                take(fut)
                last = time.monotonic()
            if stop.requested:
                continue
            limit = _stall_limit(stall_s, len(pending) < len(batches))
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
                proc.join(timeout=1.0)
            except Exception:  # noqa: BLE001
                pass


def _dask_fault(client: Any, address: str, fut: Any, batch: int) -> StudyFailedError:
    """What went wrong with a Dask future that ended in error or was cancelled."""
    if fut.status == "cancelled" or client.status != "running":
        detail = "the connection was lost" if client.status != "running" else "its batches were cancelled"
        try:
            fut.result(timeout=0)
        except BaseException as exc:  # noqa: BLE001 -- the reason Dask gives
            text = str(exc)
            if "reason:" in text:
                detail = text.split("reason:", 1)[1].split(".")[0].strip().replace("-", " ")
        return StudyFailedError(f"lost the Dask scheduler at {address} mid-study ({detail})", kind="scheduler")
    try:
        exc = fut.exception(timeout=CLUSTER_TIMEOUT_S)
    except BaseException as e:  # noqa: BLE001
        exc = e
    name = type(exc).__name__
    if name == "KilledWorker":
        return StudyFailedError(f"batch {batch} was running on Dask workers that died each time (KilledWorker: "
                                f"{_first_line(exc)}); see the worker logs", kind="worker")
    hint = ""
    if isinstance(exc, ImportError) or "No module named" in str(exc) or isinstance(exc, AttributeError):
        hint = " (is nniquad installed on every worker, in the same version?)"
    return StudyFailedError(f"a Dask worker failed on batch {batch}: {name}: {_first_line(exc)}{hint}",
                            kind="worker")


def _cancel_quietly(client: Any, futures: list[Any], timeout_s: float = 2.0) -> None:
    """Cancel the futures, but never wait long for a cluster that may be gone."""
    if not futures or client.status != "running":
        return

    def cancel() -> None:
        try:
            client.cancel(futures)
        except Exception:  # noqa: BLE001
            pass

    t = threading.Thread(target=cancel, daemon=True)
    t.start()
    t.join(timeout_s)


def _run_dask(client: Any, address: str, batches: list[list[Scenario]],
              add: Callable[[list[ScenarioResult]], None], stop: StopRequest, stall_s: float,
              note: Callable[[str], None]) -> str | None:
    futures = client.map(run_scenarios, batches, pure=False)
    pending = dict(enumerate(futures))
    last = time.monotonic()
    last_look = last
    no_worker_since: float | None = None

    def collect(i: int, fut: Any, timeout_s: float) -> bool:
        try:
            res = fut.result(timeout=timeout_s)
        except TimeoutError:  # its worker went away with it: Dask computes it again
            return False
        except Exception:  # noqa: BLE001 -- cancelled or errored meanwhile: the loop looks again
            return False
        del pending[i]
        add(res)
        return True

    try:
        while pending:
            if stop.requested:
                _stopping_note(note)
                return "interrupted"
            for i, fut in list(pending.items()):
                status = fut.status
                if status == "finished":
                    if collect(i, fut, CLUSTER_TIMEOUT_S):
                        last = time.monotonic()
                elif status in ("error", "cancelled"):
                    raise _dask_fault(client, address, fut, i)
            if not pending:
                break
            if client.status in ("closing", "closed", "failed"):
                raise StudyFailedError(f"lost the Dask scheduler at {address} mid-study (client {client.status})",
                                       kind="scheduler")
            now = time.monotonic()
            if now - last_look >= 1.0 and client.status == "running":
                last_look = now
                if cluster_threads(client, timeout_s=min(CLUSTER_TIMEOUT_S, 2.0)) == 0:
                    if no_worker_since is None:
                        no_worker_since = now
                        note(f"the cluster has no worker; waiting for one for up to "
                             f"{_stall_limit(stall_s, len(pending) < len(batches)):g} s (--stall-timeout)")
                else:
                    no_worker_since = None
            limit = _stall_limit(stall_s, len(pending) < len(batches))
            if now - last > limit:
                if no_worker_since is not None:
                    what = "the cluster has no worker left (every worker died or left)"
                else:
                    what = (f"{cluster_threads(client, timeout_s=2.0)} worker thread(s) are connected but the "
                            f"cluster has stopped making progress (a longer stall timeout, --stall-timeout, "
                            f"if one batch takes longer)")
                raise StudyFailedError(f"no batch finished in {limit:g} s on the Dask cluster at {address}: "
                                       f"{what}", kind="stalled")
            time.sleep(POLL_S)
        return None
    except KeyboardInterrupt:
        return "interrupted"
    finally:
        if pending:
            for i, fut in list(pending.items()):  # finished while we were stopping: keep them
                if fut.status == "finished" and client.status == "running":
                    collect(i, fut, 2.0)
            _cancel_quietly(client, list(pending.values()))
