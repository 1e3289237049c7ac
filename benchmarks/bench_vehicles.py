"""The committed vehicle files: ``certify --model full --budget quick``, then the certificate's own Monte Carlo.

For each file of ``notebooks/data/vehicles/`` (the Crazyflie 2.x and the 3DR
Iris, sources in the files): the certificate (default reach 2.5 m) or the
one-line refusal naming the limit, its wall time and the
full-model settling of its reference run, then ``montecarlo --samples 100
--seed 3`` on 2 workers under the default ranges: success with its Wilson 95 %
interval (target: 99 %) and the failure kinds.  About 2 minutes per
vehicle on 2 cores.  ``NNIQUAD_BENCH_VEHICLES`` (comma-separated stems) selects files.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import nniquad as nq
from nniquad.errors import NniquadError

__all__ = ["run"]

VEHICLES = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "vehicles"
SAMPLES = 100
SEED = 3
WORKERS = 2
SUCCESS_TARGET = 0.99


#: ``quick``: this vehicle only, and a study of this many scenarios.
QUICK_VEHICLE, QUICK_SAMPLES = "iris", 50


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    rows: list[dict] = []
    chosen = os.environ.get("NNIQUAD_BENCH_VEHICLES")
    names = chosen.split(",") if chosen else sorted(p.stem for p in VEHICLES.glob("*.toml"))
    if quick and not chosen:
        names = [QUICK_VEHICLE]
    samples = QUICK_SAMPLES if quick else SAMPLES
    for name in names:
        vehicle = nq.load_vehicle(VEHICLES / f"{name}.toml")
        t0 = time.perf_counter()
        try:
            cert = nq.certify(vehicle, options=nq.TuneOptions(model="full", budget="quick"))
        except NniquadError as exc:
            rows.append({"name": f"vehicles: {name}: certify refused: {str(exc)[:120]}", "value": time.perf_counter() - t0,
                         "unit": "s"})
            continue
        rows.append({"name": f"vehicles: {name}: certify --model full --budget quick", "value": time.perf_counter() - t0,
                     "unit": "s"})
        perf = cert.performance
        rows.append({"name": f"vehicles: {name}: full reference settling (kp {cert.gains.kp:.4g})",
                     "value": perf["full"]["settling_s"], "unit": "s"})
        t0 = time.perf_counter()
        study = nq.montecarlo(cert, samples=samples, seed=SEED, workers=WORKERS)
        s = study.summary
        lo, hi = s.success_ci
        fails = ", ".join(f"{k} {v}" for k, v in sorted(s.failures.items())) or "none"
        rows.append({"name": f"vehicles: {name}: MC {samples} seed {SEED}: success [{100 * lo:.1f}, {100 * hi:.1f}] %",
                     "value": 100 * s.success_rate, "unit": "%", "target": 100 * SUCCESS_TARGET,
                     "ok": s.success_rate >= SUCCESS_TARGET})
        rows.append({"name": f"vehicles: {name}: MC failures: {fails}"[:56 + 40], "value": s.n - s.n_success,
                     "unit": "count"})
        rows.append({"name": f"vehicles: {name}: MC wall time ({WORKERS} workers)", "value": time.perf_counter() - t0,
                     "unit": "s"})
    return rows
