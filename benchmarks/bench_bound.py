"""Benchmark of the time-optimal settling bound (paper vehicle, 30 deg tilt limit).

Rows: wall time of one full bound computation (both cases, best of 3 after a
warm-up that pays for CasADi's import), the two bounds, and their relative
deviation from the bang-bang closed forms.
"""

from __future__ import annotations

import time

from nniquad.analysis.bound import time_optimal_bound

__all__ = ["run"]

#: A tuner calls the bound once per vehicle; a second is plenty.
TIME_TARGET_S = 1.0
#: 1 ms on ~1.2 s; the transcription error at 200 intervals is ~1e-5.
REL_ERROR_TARGET = 1e-3


def run(quick: bool = False) -> list[dict]:
    """Rows ``{name, value, unit, target?, ok?}`` for ``benchmarks/run.py``."""
    time_optimal_bound()  # warm-up: imports casadi, loads IPOPT
    best = float("inf")
    res = None
    for _ in range(3):
        t0 = time.perf_counter()
        res = time_optimal_bound()
        best = min(best, time.perf_counter() - t0)
    assert res is not None
    return [
        {"name": "bound: wall time, both cases (best of 3)", "value": best, "unit": "s",
         "target": TIME_TARGET_S, "ok": best <= TIME_TARGET_S},
        {"name": "bound: rest_to_rest_s", "value": res.rest_to_rest_s, "unit": "s"},
        {"name": "bound: enter_band_s", "value": res.enter_band_s, "unit": "s"},
        {"name": "bound: a_max", "value": res.a_max_m_s2, "unit": "m/s^2"},
        {"name": "bound: |rel. error| rest_to_rest vs closed form", "value": abs(res.rest_to_rest_rel_error),
         "unit": "-", "target": REL_ERROR_TARGET, "ok": abs(res.rest_to_rest_rel_error) <= REL_ERROR_TARGET},
        {"name": "bound: |rel. error| enter_band vs closed form", "value": abs(res.enter_band_rel_error),
         "unit": "-", "target": REL_ERROR_TARGET, "ok": abs(res.enter_band_rel_error) <= REL_ERROR_TARGET},
    ]
