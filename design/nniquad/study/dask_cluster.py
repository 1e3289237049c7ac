"""Monte Carlo batches on a Dask distributed cluster: connecting (fast, one-line failures) and running.

:func:`connect_scheduler` fails fast on a bad or unreachable address;
:func:`run_dask` maps the batches on the cluster and watches them
(:mod:`nniquad.study.watch`): a lost scheduler, a batch whose workers died each
time it ran (``KilledWorker``), a worker that raises, and no batch finished
for the stall timeout are :class:`~nniquad.errors.StudyFailedError` faults; a
Dask worker that dies once is not a fault, the scheduler runs its batch again
elsewhere.  A scenario holds the GIL while CasADi runs, so Dask workers should
be processes with one thread each.
"""

from __future__ import annotations

import threading
import time
from typing import Any, Callable, Mapping

from nniquad.errors import MonteCarloError, StudyFailedError
from nniquad.scenarios.draws import Scenario
from nniquad.study.runs import ScenarioResult, run_scenarios
from nniquad.study.watch import POLL_S, StopRequest, first_line, stall_limit, stopping_note

__all__ = ["connect_scheduler", "close_client", "cluster_threads", "run_dask", "CONNECT_TIMEOUT_S",
           "CLUSTER_TIMEOUT_S"]

#: Time allowed to reach a Dask scheduler [s].
CONNECT_TIMEOUT_S = 5.0
#: Time allowed for one exchange with a Dask cluster during a study (fetch a batch, count workers) [s].
CLUSTER_TIMEOUT_S = 10.0


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
                              f"({first_line(exc)})") from None
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
        raise MonteCarloError(f"{where}: {exc.strerror or first_line(exc)}") from None
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
        detail = first_line(exc)
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
                                f"{first_line(exc)}); see the worker logs", kind="worker")
    hint = ""
    if isinstance(exc, ImportError) or "No module named" in str(exc) or isinstance(exc, AttributeError):
        hint = " (is nniquad installed on every worker, in the same version?)"
    return StudyFailedError(f"a Dask worker failed on batch {batch}: {name}: {first_line(exc)}{hint}",
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


def run_dask(client: Any, address: str, batches: list[list[Scenario]],
              add: Callable[[list[ScenarioResult]], None], stop: StopRequest, stall_s: float,
              note: Callable[[str], None]) -> str | None:
    """Run the batches on the cluster, handing each finished one to ``add``; ``"interrupted"`` when ``stop`` was
    requested, ``None`` when every batch finished; raises :class:`~nniquad.errors.StudyFailedError` on a fault."""
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
                stopping_note(note)
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
                             f"{stall_limit(stall_s, len(pending) < len(batches)):g} s (--stall-timeout)")
                else:
                    no_worker_since = None
            limit = stall_limit(stall_s, len(pending) < len(batches))
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
