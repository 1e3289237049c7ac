"""Benchmark of the paper audit (``nniquad prove``): wall time of the full audit, cold.

The audit runs in a fresh Python process (imports, the ~3 s symbolic model
build, cvxpy/Clarabel, python-control and the full-vehicle simulations are all
paid), which is what a user of ``nniquad prove`` waits for.  Rows: that wall
time against the 30 s target, the in-process sum of the claims' own times, the
three slowest claims, and the verdict counts.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

__all__ = ["run"]

#: Target: the full audit runs in under 30 s on the 2-core machine.
TIME_TARGET_S = 30.0
ROOT = Path(__file__).resolve().parent.parent

_SCRIPT = """
import json, time
t0 = time.perf_counter()
from nniquad.proofs.claims import run_audit
rs = run_audit()
print(json.dumps({"wall": time.perf_counter() - t0,
                  "claims": [[r.id, r.verdict, r.seconds] for r in rs]}))
"""


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _SCRIPT], cwd=ROOT, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - t0
    data = json.loads(proc.stdout.strip().splitlines()[-1])
    claims = data["claims"]
    rows = [
        {"name": "audit: wall time, cold process (all claims)", "value": wall, "unit": "s",
         "target": TIME_TARGET_S, "ok": wall <= TIME_TARGET_S},
        {"name": "audit: run_audit() time inside the process", "value": data["wall"], "unit": "s"},
        {"name": "audit: number of claims", "value": float(len(claims)), "unit": "-"},
    ]
    for cid, _, sec in sorted(claims, key=lambda c: -c[2])[:3]:
        rows.append({"name": f"audit: slowest claim {cid}", "value": sec, "unit": "s"})
    for verdict in ("holds", "holds-with-correction", "fails"):
        rows.append({"name": f"audit: verdict {verdict}", "value": float(sum(c[1] == verdict for c in claims)),
                     "unit": "claims"})
    return rows
