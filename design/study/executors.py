"""Where Monte Carlo scenarios run: in this process, a local process pool, or a Dask cluster.

Scenarios are simulated one per CasADi call (single-threaded), in batches: the
unit of work of a local :class:`concurrent.futures.ProcessPoolExecutor`
(``spawn`` start method, one process per core, workers ignore Ctrl-C) or of a
Dask distributed cluster (:func:`connect_scheduler`, which fails fast on a
bad or unreachable address).  A scenario holds the GIL while CasADi runs, so
Dask workers should be processes with one thread each.  On
``KeyboardInterrupt`` the pending batches are cancelled and the finished ones
are returned, marked partial.
"""

from __future__ import annotations

import math
import os
import signal
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nniquad.errors import MonteCarloError
from nniquad.study.runs import ScenarioResult, run_scenarios
from nniquad.study.scenarios import Scenario

__all__ = [
    "StudyRun",
    "make_batches",
    "auto_batch_size",
    "run_study",
    "connect_scheduler",
    "close_client",
    "cluster_threads",
    "CONNECT_TIMEOUT_S",
]

#: Time allowed to reach a Dask scheduler [s].
CONNECT_TIMEOUT_S = 5.0


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
        ``True`` when interrupted (only finished batches are in ``results``).
    elapsed_s
        Wall time [s].
    executor
        ``"in-process"``, ``"local process pool"`` or ``"dask tcp://..."``.
    workers, batch_size
        Worker processes (or Dask threads) and scenarios per batch.
    """

    results: list[ScenarioResult]
    n_requested: int
    partial: bool
    elapsed_s: float
    executor: str
    workers: int
    batch_size: int

    @property
    def scenarios_per_s(self) -> float:
        return len(self.results) / self.elapsed_s if self.elapsed_s > 0 else float("nan")


def _ignore_sigint() -> None:  # pool initializer: Ctrl-C is the parent's business
    signal.signal(signal.SIGINT, signal.SIG_IGN)


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


def cluster_threads(client: Any) -> int:
    """Worker threads of the cluster behind ``client`` (0 when no worker has joined yet)."""
    try:
        return int(sum(client.nthreads().values()))
    except Exception:  # noqa: BLE001
        return 0


def run_study(
    scenarios: Sequence[Scenario],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    client: Any = None,
    batch_size: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
) -> StudyRun:
    """Run the scenarios in batches and collect the results, sorted by index.

    Parameters
    ----------
    scenarios
        From :func:`draw_scenarios`.
    workers
        Local worker processes (default ``os.cpu_count()``); 1 runs in this
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

    Returns
    -------
    StudyRun
        ``partial`` is set when interrupted by ``KeyboardInterrupt``; the
        finished batches are kept and the pending ones cancelled.

    Raises
    ------
    MonteCarloError
        Bad options, an unreachable scheduler, a failed worker.
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
    t0 = time.perf_counter()
    own_client = False
    if client is None and scheduler:
        client = connect_scheduler(scheduler, connect_timeout_s)
        own_client = True
    collected: list[ScenarioResult] = []
    partial = False
    done = 0

    def _add(res: list[ScenarioResult]) -> None:
        nonlocal done
        collected.extend(res)
        done += len(res)
        if progress is not None:
            progress(done, total)

    try:
        if client is not None:
            n_workers = max(1, cluster_threads(client))
            executor = f"dask {getattr(client.scheduler, 'address', scheduler)}"
        else:
            n_workers = int(workers or os.cpu_count() or 1)
            executor = "in-process" if n_workers == 1 else "local process pool"
        bs = auto_batch_size(total, n_workers) if batch_size is None else int(batch_size)
        batches = make_batches(scenarios, bs)
        if client is not None:
            partial = _run_dask(client, batches, _add)
        elif n_workers == 1:
            try:
                for b in batches:
                    _add(run_scenarios(b))
            except KeyboardInterrupt:
                partial = True
        else:
            partial = _run_pool(n_workers, batches, _add)
    finally:
        if own_client:
            close_client(client)
    collected.sort(key=lambda r: r.index)
    return StudyRun(collected, total, partial, time.perf_counter() - t0, executor, n_workers, bs)


def _run_pool(n_workers: int, batches: list[list[Scenario]], add: Callable[[list[ScenarioResult]], None]) -> bool:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    pool = ProcessPoolExecutor(max_workers=min(n_workers, len(batches)),
                               mp_context=multiprocessing.get_context("spawn"),
                               initializer=_ignore_sigint)
    futures = []
    taken: set[int] = set()
    interrupted = False
    try:
        futures = [pool.submit(run_scenarios, b) for b in batches]
        for fut in as_completed(futures):
            taken.add(id(fut))
            add(fut.result())
    except KeyboardInterrupt:
        interrupted = True
        for fut in futures:  # finished but not yet collected: keep them
            if id(fut) not in taken and fut.done() and not fut.cancelled() and fut.exception() is None:
                try:
                    add(fut.result())
                except KeyboardInterrupt:
                    pass
    except BrokenProcessPool as exc:
        raise MonteCarloError(f"a local worker process died ({exc})") from None
    finally:
        if interrupted:
            procs = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=False, cancel_futures=True)
            for proc in procs:  # stop the running batches now (their results would be discarded)
                try:
                    proc.terminate()
                except Exception:  # noqa: BLE001
                    pass
            for proc in procs:
                proc.join(timeout=5)
        else:
            pool.shutdown(wait=True, cancel_futures=True)
    return interrupted


def _run_dask(client: Any, batches: list[list[Scenario]], add: Callable[[list[ScenarioResult]], None]) -> bool:
    from distributed import as_completed

    futures = client.map(run_scenarios, batches, pure=False)
    taken: set[str] = set()
    try:
        for fut in as_completed(futures, loop=client.loop):  # not the default client: name its loop
            taken.add(fut.key)
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001
                client.cancel(futures)
                detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
                raise MonteCarloError(f"a Dask worker failed: {type(exc).__name__}: {detail} "
                                      "(is nniquad installed on every worker?)") from None
            add(res)
    except KeyboardInterrupt:
        for fut in futures:
            if fut.key not in taken and fut.status == "finished":
                try:
                    add(fut.result(timeout=1))
                except BaseException:  # noqa: BLE001 -- keep what we have
                    pass
        try:
            client.cancel(futures)
        except Exception:  # noqa: BLE001
            pass
        return True
    return False
