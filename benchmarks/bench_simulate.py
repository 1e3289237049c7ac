"""Simulation throughput (simulated seconds per wall second) at the accuracy the tests establish.

Rows: the full vehicle as one 20 s trajectory and as a batch of 100 gain sets
(target: the batch in under 10 s on a 2-core machine), the same 100 runs one
by one and the ratio of the two throughputs (target: the batch, a serial CasADi
``map`` per thread on one thread per core, at least 1.8 x one by one on 2 cores), the linear and reduced
models, and the accuracy of the full model's RK4 (1 ms) against scipy's DOP853
(rtol 1e-11) over 4 s from the paper's initial state.  The one-off C
compilation is paid in a warm-up and reported separately.
"""

from __future__ import annotations

import time

import numpy as np

from nniquad import sim
from timing import best_of  # benchmarks/timing.py
from nniquad.laws.nni import PAPER_GAINS, Gains
from nniquad.sim import SimOptions, SimParams, simulate
from nniquad.sim.runner import batch_threads
from nniquad.model.vehicle import PAPER_VEHICLE

__all__ = ["run"]

HORIZON_S = 20.0
BATCH = 100
BATCH_TARGET_S = 10.0
#: A batch must run at least this many times the throughput of the same runs one by one.
BATCH_RATIO_TARGET = 1.8
ACCURACY_TARGET_M = 1e-4


def _gain_sets(n: int) -> list[Gains]:
    rng = np.random.default_rng(0)
    out = []
    while len(out) < n:
        g = Gains(kp=rng.uniform(2, 12), Gamma=rng.uniform(10, 400), delta=rng.uniform(0.3, 1.5))
        if PAPER_VEHICLE.m * g.kp * g.delta > 1:  # Routh-stable sets, as a tuner would try
            out.append(g)
    return out


def _accuracy() -> float:
    from scipy.integrate import solve_ivp

    o = SimOptions(model="full", horizon_s=4.0)
    tr = simulate(PAPER_VEHICLE, PAPER_GAINS, o)[0]
    P = SimParams.from_options(PAPER_VEHICLE, PAPER_GAINS, o).vector()
    f = sim.rhs_function("full")
    e = np.zeros(len(sim.EXO_FIELDS))
    sol = solve_ivp(lambda t, x: np.asarray(f(x, e, P)).ravel(), (0, 4.0), tr.state[0], method="DOP853",
                    rtol=1e-11, atol=1e-12, t_eval=tr.t)
    return float(np.max(np.abs(tr.xy - sol.y[[0, 2]].T)))


#: ``quick``: a batch of this many runs (the ratio still needs several runs per thread).
QUICK_BATCH = 40


def run(quick: bool = False) -> list[dict]:
    """Rows for ``benchmarks/run.py``; ``quick``: the batch rows with :data:`QUICK_BATCH` runs (target scaled)."""
    n_batch = QUICK_BATCH if quick else BATCH
    batch_target = BATCH_TARGET_S * n_batch / BATCH
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    rows: list[dict] = []
    t0 = time.perf_counter()
    for model in sim.MODELS:  # warm-up: builds (and on a fresh machine compiles) each model
        simulate(PAPER_VEHICLE, PAPER_GAINS, SimOptions(model=model, horizon_s=0.1))
    rows.append({"name": "simulate: warm-up (build/compile/load, 3 models)", "value": time.perf_counter() - t0,
                 "unit": "s"})
    compiled = sum("compiled" in v for v in sim.compile_status().values())
    rows.append({"name": "simulate: functions running as compiled C", "value": compiled, "unit": "count"})

    for model in sim.MODELS:
        o = SimOptions(model=model, horizon_s=HORIZON_S)
        wall = best_of(lambda: simulate(PAPER_VEHICLE, PAPER_GAINS, o), 3)
        rows.append({"name": f"simulate: {model}, one {HORIZON_S:g} s run (best of 3)", "value": wall, "unit": "s"})
        rows.append({"name": f"simulate: {model}, one run, throughput", "value": HORIZON_S / wall,
                     "unit": "sim-s/s"})

    gains = _gain_sets(n_batch)
    o = SimOptions(model="full", horizon_s=HORIZON_S)
    simulate(PAPER_VEHICLE, gains, o.with_(horizon_s=0.1))  # builds the mapped function
    simulate(PAPER_VEHICLE, gains[0], o.with_(horizon_s=0.1))  # builds the single-run function
    # the batch and the same 100 runs one by one, alternated (best of 2 each), so that a load that comes
    # and goes on a shared machine hits both alike (target: batch throughput >= 1.8 x one by one)
    batch_walls, single_walls = [], []
    for _ in range(2):
        t0 = time.perf_counter()
        simulate(PAPER_VEHICLE, gains, o)
        batch_walls.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for g in gains:
            simulate(PAPER_VEHICLE, g, o)
        single_walls.append(time.perf_counter() - t0)
    wall, single = min(batch_walls), min(single_walls)
    rows.append({"name": f"simulate: full, batch {n_batch} x {HORIZON_S:g} s (best of 2)", "value": wall, "unit": "s",
                 "target": batch_target, "ok": wall <= batch_target})
    rows.append({"name": "simulate: full, batch, throughput", "value": n_batch * HORIZON_S / wall, "unit": "sim-s/s"})
    rows.append({"name": f"simulate: full, {n_batch} x {HORIZON_S:g} s one by one (best of 2)", "value": single,
                 "unit": "s"})
    ratio = single / wall
    rows.append({"name": f"simulate: batch / one-by-one throughput ({batch_threads(n_batch)} threads)",
                 "value": ratio, "unit": "x", "target": BATCH_RATIO_TARGET, "ok": ratio >= BATCH_RATIO_TARGET})

    err = _accuracy()
    rows.append({"name": "simulate: full RK4 1 ms vs DOP853, max |xy| error, 4 s", "value": err, "unit": "m",
                 "target": ACCURACY_TARGET_M, "ok": err <= ACCURACY_TARGET_M})
    return rows
