"""``nniquad verify`` of a schema-2 certificate, from a cold start (target: under 3 s).

The command runs as a user runs it: a fresh interpreter (``python -m nniquad
verify CERT``), so the time includes the imports, building the symbolic model,
the reference runs and the rebuild of the cascade section.  A second row is the
in-process re-verification of the same document (every cache warm), as a ratio
to the cold run measured in the same session.

The certificate is ``notebooks/data/full_model_certificate.json`` (override with
``NNIQUAD_BENCH_VERIFY_CERT``).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

__all__ = ["run"]

ROOT = Path(__file__).resolve().parents[1]
CERT = ROOT / "notebooks" / "data" / "full_model_certificate.json"
#: Target: a cold ``nniquad verify`` of the committed certificate in under 3 s (the sampled-data cascade
#: certificate's own target was 10 s).
TARGET_S = 3.0


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    cert = Path(os.environ.get("NNIQUAD_BENCH_VERIFY_CERT", CERT))
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "nniquad", "verify", str(cert)], capture_output=True, text=True)
    cold = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"nniquad verify {cert.name} failed (exit {proc.returncode}): "
                           f"{(proc.stderr.strip().splitlines() or proc.stdout.strip().splitlines())[-1:]}")
    from nniquad.certificates import verify_certificate

    verify_certificate(cert)  # fills this process's caches
    t1 = time.perf_counter()
    res = verify_certificate(cert)
    warm = time.perf_counter() - t1
    return [
        {"name": f"verify {cert.name} (cold CLI, {len(res.checks)} checks)", "value": cold, "unit": "s",
         "target": TARGET_S, "ok": cold < TARGET_S},
        {"name": "verify again in the same process (caches warm) / cold", "value": warm / cold, "unit": "x"},
    ]
