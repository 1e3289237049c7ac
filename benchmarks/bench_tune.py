"""Tuner targets, each measured by running the tuner as ``nniquad tune`` does.

* ``reduced``, ``--roa-radius 0``: settling within 5 % of ``enter_band_s``;
* ``reduced`` with the default certified reach (2.5 m): the settling time the
  guarantee costs;
* ``full``, ``--roa-radius 0``: settling within 1.6 x ``enter_band_s`` with the
  peak *actual* tilt within the tilt limit + 1 deg;
* every tuning run under 2 minutes on the 2-core reference machine.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

TIME_TARGET_S = 120.0


def run(quick: bool = False) -> list[dict]:
    """Rows for ``benchmarks/run.py``; ``quick``: the ``reduced`` tune without the reach only."""
    from nniquad.tuning.tune import DEFAULT_ROA_RADIUS_M, TILT_SLACK_DEG, TuneOptions, tune
    from nniquad.model.vehicle import PAPER_VEHICLE

    rows: list[dict] = []
    results = {}
    cases = (
        ("reduced, reach off", TuneOptions(model="reduced", roa_radius_m=0.0)),
        (f"reduced, reach {DEFAULT_ROA_RADIUS_M:g} m", TuneOptions(model="reduced")),
        ("full, reach off", TuneOptions(model="full", roa_radius_m=0.0)),
    )
    for label, opts in cases[:1] if quick else cases:
        t0 = time.perf_counter()
        res = tune(PAPER_VEHICLE, opts)
        wall = time.perf_counter() - t0
        results[label] = res
        rows.append({"name": f"tune {label}: time", "value": wall, "unit": "s", "target": f"< {TIME_TARGET_S:g}",
                     "ok": wall < TIME_TARGET_S})
        rows.append({"name": f"tune {label}: settling", "value": res.settling_s, "unit": "s", "target": "",
                     "ok": True})
        target = {"reduced, reach off": 1.05, "full, reach off": 1.6}.get(label)
        rows.append({"name": f"tune {label}: ratio to enter_band_s", "value": res.ratio_to_bound, "unit": "x",
                     "target": "" if target is None else f"<= {target:g}",
                     "ok": True if target is None else res.ratio_to_bound <= target})
        rows.append({"name": f"tune {label}: spread of per-seed optima", "value": res.rerun_spread_s(), "unit": "s",
                     "target": "", "ok": True})
        if opts.model == "full":
            cap = opts.tilt_limit_deg + TILT_SLACK_DEG
            rows.append({"name": f"tune {label}: peak actual tilt", "value": res.metrics.peak_tilt_deg,
                         "unit": "deg", "target": f"<= {cap:g}", "ok": res.metrics.peak_tilt_deg <= cap})
            rows.append({"name": f"tune {label}: certified reach", "value": res.certified_reach_m, "unit": "m",
                         "target": "", "ok": True})
    if quick:
        return rows
    off, on = results["reduced, reach off"], results[f"reduced, reach {DEFAULT_ROA_RADIUS_M:g} m"]
    rows.append({"name": "reduced: settling the reach guarantee costs", "value": on.settling_s - off.settling_s,
                 "unit": "s", "target": "", "ok": True})
    return rows
