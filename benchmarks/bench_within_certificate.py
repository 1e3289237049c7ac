"""Certified => converges: ``nniquad montecarlo --within-certificate --samples 1000`` on the committed certificate.

The target: every scenario drawn inside the certificate's cascade box
and region of attraction, at its rate, without noise or wind, converges (0
failures).  The command runs as a user runs it (a subprocess of the CLI, all
cores); the rows are its wall time, the converged count and the failures.

The certificate is ``notebooks/data/full_model_certificate.json`` (override with
``NNIQUAD_BENCH_WITHIN_CERT``); one without a ``cascade`` section certifies no
box, and the benchmark then gives a single row that says so (no target).
``NNIQUAD_BENCH_WITHIN_SAMPLES`` (default 1000) sets the count for a quick check.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

__all__ = ["run"]

ROOT = Path(__file__).resolve().parents[1]
CERT = ROOT / "notebooks" / "data" / "full_model_certificate.json"
SAMPLES = 1000
SEED = 0


#: ``quick``: this many scenarios.
QUICK_SAMPLES = 100


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    cert = Path(os.environ.get("NNIQUAD_BENCH_WITHIN_CERT", CERT))
    samples = int(os.environ.get("NNIQUAD_BENCH_WITHIN_SAMPLES", QUICK_SAMPLES if quick else SAMPLES))
    if samples <= 0:
        raise ValueError(f"NNIQUAD_BENCH_WITHIN_SAMPLES must be a positive integer, got {samples}")
    doc = json.loads(cert.read_text())
    if not isinstance(doc.get("cascade"), dict):
        msg = f"within-certificate: skipped, {cert.name} has no cascade section (certifies no box)"
        print(f"[bench] {msg}", file=sys.stderr)
        return [{"name": msg, "value": float("nan"), "unit": "-"}]
    cmd = [sys.executable, "-m", "nniquad", "montecarlo", "--certificate", str(cert), "--within-certificate",
           "--samples", str(samples), "--seed", str(SEED)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    m = re.search(r"within certificate: (\d+)/(\d+) converged", proc.stdout)
    if m is None or proc.returncode not in (0, 1):
        raise RuntimeError(f"montecarlo --within-certificate failed (exit {proc.returncode}): "
                           f"{proc.stderr.strip().splitlines()[-1:] or proc.stdout[-500:]}")
    converged, total = int(m.group(1)), int(m.group(2))
    failures = total - converged
    for line in proc.stdout.splitlines():
        if line.startswith("FAILED within certificate"):
            print(f"[bench] {line}", file=sys.stderr)
    box = doc["cascade"].get("box", {})
    shown = ", ".join(f"{k.removesuffix('_factor')} {v[0]:g}-{v[1]:g}" for k, v in box.items())
    return [
        {"name": f"within-certificate: {samples} scenarios ({shown})", "value": wall, "unit": "s"},
        {"name": "within-certificate: converged", "value": converged, "unit": f"of {total}"},
        {"name": "within-certificate: failures", "value": failures, "unit": "scen", "target": 0,
         "ok": failures == 0 and proc.returncode == 0},
    ]
