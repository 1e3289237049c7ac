"""Estimates of the memory and time a request needs, checked before the work starts.

A simulation keeps its states and outputs at every output sample and one
exogenous-input row (noise, sample flag, gust) per RK4 step, so its memory is

    runs * n_samples * (n_states + n_outputs) * 8  +  n_exo * n_steps * 5 * 8  bytes

(``n_exo`` is 1 when the runs share the input, else ``runs``).  A Monte Carlo
study holds every drawn scenario and every result (about
:data:`MC_BYTES_PER_SCENARIO` each, measured), plus one simulation per worker.
The time is estimated from RK4 steps per second measured on one core
(:data:`STEPS_PER_S`); it is a rough figure, given in the message, and only a
request beyond :data:`nniquad.config.RUN_TIME_LIMIT_S` is refused for its time.

The memory limit is :data:`nniquad.config.MEMORY_FRACTION` of the memory
available when the request starts (``MemAvailable`` of ``/proc/meminfo``, else
the physical memory from ``os.sysconf``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from nniquad.config import MEMORY_FRACTION, RUN_TIME_LIMIT_S
from nniquad.errors import NniquadError, ResourceError
from nniquad.io import format_bytes

__all__ = [
    "STEPS_PER_S",
    "EXO_COLUMNS",
    "MC_BYTES_PER_SCENARIO",
    "WORKER_PROCESS_BYTES",
    "Estimate",
    "available_memory_bytes",
    "format_duration",
    "simulation_estimate",
    "montecarlo_estimate",
    "check_estimate",
    "usable_cpu_count",
]

#: RK4 steps per second of one run on one core (measured: linear 2.9e6, reduced 2.4e6, full 3.5e5; rounded down).
STEPS_PER_S: dict[str, float] = {"linear": 2.0e6, "reduced": 2.0e6, "full": 3.0e5}
#: Memory a Monte Carlo study keeps per scenario: the scenario (2.4 kB), its result and its JSON (measured, rounded up).
MC_BYTES_PER_SCENARIO: int = 10 * 1024
#: Memory of one local worker process (Python, numpy, CasADi and the compiled simulator; measured ~120 MiB).
WORKER_PROCESS_BYTES: int = 150 * 2**20
#: Number of states and outputs per model (as in :data:`nniquad.sim.STATE_NAMES` / ``OUTPUT_NAMES``;
#: a test checks they agree, so this module needs no CasADi import).
MODEL_SIZES: dict[str, tuple[int, int]] = {"linear": (8, 5), "reduced": (8, 5), "full": (21, 12)}
#: Per-step exogenous inputs (:data:`nniquad.sim.EXO_FIELDS`; a test checks they agree).
EXO_COLUMNS = 11
_FLOAT = 8


def available_memory_bytes() -> int:
    """Memory available to a new request: ``MemAvailable`` (Linux), else the physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not a POSIX system
        return 2**63


def format_duration(seconds: float) -> str:
    """A duration with a readable unit: ``'3.2 min'``, ``'950 years'``."""
    s = float(seconds)
    if not math.isfinite(s):
        return "forever"
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("h", 3600), ("min", 60)):
        if s >= size:
            return f"{s / size:.3g} {unit}"
    return f"{s:.2g} s"


@dataclass(frozen=True)
class Estimate:
    """What a request needs: ``memory_bytes`` at its peak and ``seconds`` of wall time (rough)."""

    what: str
    memory_bytes: float
    seconds: float

    def describe(self) -> str:
        return f"about {format_bytes(self.memory_bytes)} of memory and {format_duration(self.seconds)}"


def _steps(horizon_s: float, dt_s: float, output_dt_s: float) -> tuple[float, float]:
    """(output samples + 1, RK4 steps) as floats: a 1e9 s horizon must not build a giant int first."""
    n_samples = math.ceil(horizon_s / output_dt_s - 1e-9) if horizon_s / output_dt_s < 1e15 else horizon_s / output_dt_s
    k = round(output_dt_s / dt_s)
    return float(n_samples) + 1.0, float(n_samples) * k


def simulation_estimate(model: str, horizon_s: float, dt_s: float, output_dt_s: float, *, runs: int = 1,
                        shared_exo: bool = True, workers: int = 1) -> Estimate:
    """Memory and time of ``runs`` simulations of ``model`` (see the module docstring)."""
    nx, ny = MODEL_SIZES[model]
    n_out, n_steps = _steps(horizon_s, dt_s, output_dt_s)
    memory = runs * n_out * (nx + ny) * _FLOAT + (1 if shared_exo else runs) * n_steps * EXO_COLUMNS * _FLOAT
    seconds = runs * n_steps / STEPS_PER_S[model] / max(1, workers)
    return Estimate(f"{model} simulation of {horizon_s:g} s", memory, seconds)


def montecarlo_estimate(samples: int, horizon_s: float, dt_s: float, output_dt_s: float, workers: int) -> Estimate:
    """Memory and time of a Monte Carlo study: every scenario and result kept, one full run per worker."""
    # a 500-digit --samples is a valid int but no float: clamp far beyond any machine first
    samples, workers = min(int(samples), 10**30), min(int(workers), 10**30)
    one = simulation_estimate("full", horizon_s, dt_s, output_dt_s)
    extra = WORKER_PROCESS_BYTES if workers > 1 else 0
    memory = float(samples) * MC_BYTES_PER_SCENARIO + max(1, workers) * (one.memory_bytes + extra)
    seconds = float(samples) * one.seconds / max(1, min(workers, samples))
    return Estimate(f"{samples} scenarios of {horizon_s:g} s", memory, seconds)


def check_estimate(estimate: Estimate, *, option: str, available_bytes: int | None = None,
                   error: type[NniquadError] = ResourceError) -> Estimate:
    """Refuse, with the estimate in one line, a request this machine cannot run.

    Parameters
    ----------
    estimate
        From :func:`simulation_estimate` or :func:`montecarlo_estimate`.
    option
        The options to blame (``"--horizon 1e+09"``).
    available_bytes
        Memory limit before :data:`nniquad.config.MEMORY_FRACTION` (default :func:`available_memory_bytes`).
    error
        Error class raised.

    Raises
    ------
    error
        More memory than the fraction of the available memory, or a run time
        beyond :data:`nniquad.config.RUN_TIME_LIMIT_S`.
    """
    avail = available_memory_bytes() if available_bytes is None else int(available_bytes)
    limit = MEMORY_FRACTION * avail
    if not estimate.memory_bytes <= limit:
        raise error(f"{option}: the request ({estimate.what}) needs {estimate.describe()}, but this machine has "
                    f"{format_bytes(avail)} available; reduce the request")
    if not estimate.seconds <= RUN_TIME_LIMIT_S:
        raise error(f"{option}: the request ({estimate.what}) needs {estimate.describe()}, more than the "
                    f"{format_duration(RUN_TIME_LIMIT_S)} accepted; reduce the request")
    return estimate


def usable_cpu_count() -> int:
    """CPUs this process may actually use: its affinity mask, capped by a cgroup v2 CPU quota.

    ``os.cpu_count()`` counts the machine's CPUs even when the process is
    restricted (``taskset``, a container's cpuset, ``cpu.max``); threads and
    worker processes beyond the usable CPUs only take turns.  The affinity mask is
    ``os.sched_getaffinity(0)`` where the platform has it; the quota is
    ``/sys/fs/cgroup/cpu.max`` (``QUOTA PERIOD``, rounded up), when set.
    """
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    try:
        with open("/sys/fs/cgroup/cpu.max", encoding="ascii") as fh:
            quota, period = fh.read().split()[:2]
        if quota != "max" and float(period) > 0:
            n = min(n, max(1, math.ceil(float(quota) / float(period))))
    except (OSError, ValueError):
        pass
    return max(1, int(n))
