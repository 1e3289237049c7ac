"""Cold commands: ``nniquad --help``, ``lmi``, ``prove`` and ``verify CERT`` as fresh processes.

Each command runs as a user runs it, a new interpreter (``python -m nniquad
...``), on the committed certificate ``notebooks/data/full_model_certificate.json``
(override with ``NNIQUAD_BENCH_COLD_CERT``; ``CERT`` in the rows).  The code
cache (:mod:`nniquad.codecache`) lives in a temporary folder of this run: one
untimed run of each command fills it (as a user's first run after an install or
an edit does), then the command is timed ``NNIQUAD_BENCH_COLD_REPEAT`` times
(default 5; 1 with ``--quick``) and the row is the median wall time against the
command's target (every run's time is in the JSON, ``runs_s``).  One more row
(not with ``--quick``) times ``verify`` with an empty cache (every CasADi
function built from sympy again, the simulator compiled), for information.

A ``verify`` that finds a failed check (exit status 1) has done all its work
and is timed like a passing one; any other exit status is an error.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

__all__ = ["run", "TARGETS_S"]

ROOT = Path(__file__).resolve().parents[1]
CERT = ROOT / "notebooks" / "data" / "full_model_certificate.json"
REPEAT = 5

#: The cold-start targets [s], wall time of one cold process.
TARGETS_S = {"--help": 0.5, "lmi": 2.0, "prove": 5.0, "verify": 3.0}


def _time_once(args: list[str], env: dict[str, str], ok_codes: tuple[int, ...]) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "nniquad", *args], cwd=ROOT, env=env, capture_output=True,
                          text=True)
    wall = time.perf_counter() - t0
    if proc.returncode not in ok_codes:
        tail = (proc.stderr.strip().splitlines() or proc.stdout.strip().splitlines() or ["(no output)"])[-1]
        raise RuntimeError(f"nniquad {' '.join(args)} exited {proc.returncode}: {tail}")
    return wall


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target, ok}`` for ``benchmarks/run.py``; ``quick``: one timed run each, no
    empty-cache row."""
    cert = Path(os.environ.get("NNIQUAD_BENCH_COLD_CERT", CERT))
    repeat = int(os.environ.get("NNIQUAD_BENCH_COLD_REPEAT", 1 if quick else REPEAT))
    if repeat <= 0:
        raise ValueError(f"NNIQUAD_BENCH_COLD_REPEAT must be a positive integer, got {repeat}")
    commands = {"--help": (["--help"], (0,)), "lmi": (["lmi"], (0,)), "prove": (["prove"], (0,)),
                "verify": (["verify", str(cert)], (0, 1))}
    rows = []
    load_before = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    with tempfile.TemporaryDirectory(prefix="nniquad-bench-cold-") as folder:
        env = {**os.environ, "NNIQUAD_CACHE_DIR": folder}
        empty = None if quick else _time_once(commands["verify"][0], env, commands["verify"][1])  # fills the cache
        for name, (args, ok_codes) in commands.items():
            _time_once(args, env, ok_codes)  # untimed: the cache holds every function this command needs
            walls = [_time_once(args, env, ok_codes) for _ in range(repeat)]
            wall = statistics.median(walls)
            label = "nniquad verify CERT" if name == "verify" else f"nniquad {name}"
            rows.append({"name": f"{label}, cold (median of {repeat})", "value": wall, "unit": "s",
                         "target": TARGETS_S[name], "ok": wall < TARGETS_S[name], "runs_s": walls})
    if empty is not None:
        rows.append({"name": "nniquad verify CERT, empty code cache (first run)", "value": empty, "unit": "s"})
    # wall times on a shared machine depend on its load: the 1-minute load average before and after, for reading them
    load_after = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    rows.append({"name": f"1-min load average before the runs ({os.cpu_count()} CPUs)", "value": load_before,
                 "unit": "procs"})
    rows.append({"name": "1-min load average after the runs", "value": load_after, "unit": "procs"})
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
