"""Time to build and solve each LMI for the paper's gains, and the whole ``nniquad lmi`` run.

Each LMI is timed warm (second call: cvxpy and the lambdified model are loaded),
which is what a sweep pays per gain set.  The CLI row is a cold subprocess, the
number a user sees; its target (< 5 s on the 2-core reference machine) comes
from the issue.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from timing import best_of  # noqa: E402  (benchmarks/timing.py)

#: Target: a cold ``nniquad lmi`` in under 2 s.
CLI_TARGET_S = 2.0


def run(quick: bool = False) -> list[dict]:
    """Rows for ``benchmarks/run.py``; ``quick``: only ``run_all`` and the cold command."""
    from nniquad.analysis import lmi
    from nniquad.analysis.reduced_loop import PAPER_LOOP as loop
    from nniquad.config import TILT_LIMIT_DEG

    m, g = loop.m, loop.g
    A, B, C, D = loop.plant_matrices()
    Ac, Bc, Cc, _ = loop.controller_matrices()
    u0 = lmi.axis_acceleration_limit(g, TILT_LIMIT_DEG)
    cases = {
        "ni_lemma_paper[plant]": lambda: lmi.ni_lemma_paper(A, B, C),
        "ni_lemma_dissipation[plant]": lambda: lmi.ni_lemma_dissipation(A, B, C, D),
        "ni_lemma_lanzon_petersen[plant]": lambda: lmi.ni_lemma_lanzon_petersen(A, B, C, D),
        "sni_lemma[controller]": lambda: lmi.sni_lemma(Ac, Bc, Cc),
        "ni_dissipation_strict[controller]": lambda: lmi.ni_dissipation_strict(Ac, Bc, Cc),
        "closed_loop_decay (bisection)": lambda: lmi.closed_loop_decay(loop),
        "robust_mass_decay[common_P]": lambda: lmi.robust_mass_decay(loop, 0.8 * m, 1.2 * m),
        "robust_mass_decay[pdlf] (bisection)": lambda: lmi.robust_mass_decay(loop, 0.8 * m, 1.2 * m, parameter_dependent=True),
        "region_of_attraction[x]": lambda: lmi.region_of_attraction(loop, u0),
        "run_all": lambda: lmi.run_all(loop),
    }
    if quick:
        cases = {"run_all": cases["run_all"]}
    rows = [{"name": f"lmi {name} build+solve", "value": best_of(fn, 3, warmup=True), "unit": "s"} for name, fn in cases.items()]
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "nniquad", "lmi"], cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    rows.append({"name": "nniquad lmi (cold subprocess, wall)", "value": wall, "unit": "s",
                 "target": CLI_TARGET_S, "ok": proc.returncode == 0 and wall < CLI_TARGET_S})
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
