"""Monte Carlo throughput (scenarios per wall second) of ``nniquad montecarlo`` on the local process pool.

Rows: scenarios/s of the same ``SCALING`` scenarios of 20 s run by 1 worker
(in this process, what ``--workers 1`` does) and by 2 worker processes (the
local pool, process start included, what ``--workers 2`` does), their ratio
(measured in the same run), and a whole study of ``SAMPLES`` scenarios of 20 s
on all cores (default pool, batches as the command sizes them), with the
target of 1000 scenarios in under 300 s on a 2-core machine.

The gain set is the tuned one of the certificate tests (a real certificate is
built first, about 4 s, and not timed).  Environment variables for a quick
check: ``NNIQUAD_BENCH_MC_SAMPLES`` (default 1000) and
``NNIQUAD_BENCH_MC_SCALING`` (default 200); the target is scaled to the count.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import nniquad.study as mc
from nniquad.analysis.cascade.box_certificate import ParameterBox
from nniquad.certificates import build_certificate, load_certificate, write_certificate
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.laws.nni import Gains
from nniquad.model.vehicle import PAPER_VEHICLE

__all__ = ["run"]

HORIZON_S = 20.0
SAMPLES = 1000
SCALING = 200
STUDY_TARGET_S = 300.0  # for 1000 scenarios
SEED = 2024

GAINS = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56021438245625, attitude_zeta=1.1320049751084362,
                       attitude_accel_limit_rad_s2=31.13986455385077)

# the test design tolerates only a slightly slower motor: its cascade box is a tenth of the Monte Carlo
# ranges (log scale), as the widest-box search finds
SMALL_BOX = ParameterBox.monte_carlo_default().scaled(0.1)


def _count(name: str, default: int) -> int:
    raw = os.environ.get(name)
    if raw is None:
        return default
    value = int(raw)
    if value <= 0:
        raise ValueError(f"{name} must be a positive integer, got {raw!r}")
    return value


def _setup() -> mc.StudySetup:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "cert.json"
        write_certificate(build_certificate(PAPER_VEHICLE, GAINS, inner=INNER, model="full", box=SMALL_BOX), path)
        return mc.study_setup(load_certificate(path), horizon_s=HORIZON_S)


#: ``quick``: the study and the scaling runs at these sizes (the target scales with the count).
QUICK_SAMPLES, QUICK_SCALING = 100, 40


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    samples = _count("NNIQUAD_BENCH_MC_SAMPLES", QUICK_SAMPLES if quick else SAMPLES)
    scaling = _count("NNIQUAD_BENCH_MC_SCALING", QUICK_SCALING if quick else SCALING)
    setup = _setup()
    mc.run_scenarios(mc.draw_scenarios(1, SEED, cert=setup, horizon_s=0.1))  # build/load the model here
    rows: list[dict] = []

    scenarios = mc.draw_scenarios(scaling, SEED, cert=setup)
    one = mc.run_study(scenarios, workers=1)
    two = mc.run_study(scenarios, workers=2)
    if one.results != two.results:
        raise RuntimeError("1 and 2 workers gave different results for the same scenarios")
    rows.append({"name": f"montecarlo: {scaling} x {HORIZON_S:g} s, 1 worker (in-process)",
                 "value": one.scenarios_per_s, "unit": "scen/s"})
    rows.append({"name": "montecarlo: same, 2 workers (pool, start incl.)", "value": two.scenarios_per_s,
                 "unit": "scen/s"})
    rows.append({"name": "montecarlo: speed-up 2 workers / 1 worker",
                 "value": two.scenarios_per_s / one.scenarios_per_s, "unit": "x"})

    target = STUDY_TARGET_S * samples / SAMPLES
    t0 = time.perf_counter()
    study = mc.run_study(mc.draw_scenarios(samples, SEED + 1, cert=setup))
    wall = time.perf_counter() - t0
    summary = mc.summarize(study.results)
    rows.append({"name": f"montecarlo: {samples} x {HORIZON_S:g} s, {study.workers} workers, batches of "
                         f"{study.batch_size}", "value": wall, "unit": "s", "target": target, "ok": wall <= target})
    rows.append({"name": "montecarlo: that study, throughput", "value": study.scenarios_per_s, "unit": "scen/s"})
    rows.append({"name": "montecarlo: that study, success rate (default ranges)", "value": 100 * summary.success_rate,
                 "unit": "%"})
    return rows
