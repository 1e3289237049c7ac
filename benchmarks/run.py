"""Run every benchmark in this folder, print a table and write JSON.

Each ``bench_*.py`` module defines ``run(quick: bool = False) -> list[dict]``;
every dict is one row with at least ``name``, ``value``, ``unit`` and, where a
target exists, ``target`` (same unit, or a text such as ``"<= 2"``) and ``ok``
(bool).  Timings that are compared with each other are measured in the same run
and reported as ratios.

Two modes (``make bench`` and ``make bench-quick``):

* full: every figure at the size its target is stated for (about 15 minutes on
  the 2-core reference machine);
* ``--quick``: the same table with smaller sizes, at least one row per area
  (about 3 minutes); a row whose size differs from the full one says so in its
  name, and its target is scaled where the target is a size-dependent time.

Usage: ``python benchmarks/run.py [--quick] [--json FILE] [--only NAME,...]``
"""

from __future__ import annotations

import argparse
import importlib.util
import inspect
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))  # benchmarks/timing.py

from nniquad.io import atomic_write_json  # noqa: E402

#: Target: ``make bench`` finishes within 15 minutes and ``make bench-quick`` within 3 on 2 cores.
FULL_BUDGET_S = 15 * 60.0
QUICK_BUDGET_S = 3 * 60.0


def _modules(only: set[str] | None):
    for path in sorted(HERE.glob("bench_*.py")):
        name = path.stem.removeprefix("bench_")
        if only and name not in only:
            continue
        spec = importlib.util.spec_from_file_location(path.stem, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        yield name, module


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", default=None, help="write all rows to this JSON file")
    parser.add_argument("--only", default=None, help="comma-separated benchmark names (file stems without bench_)")
    parser.add_argument("--quick", action="store_true", help="smaller sizes, one row per area (about 3 minutes)")
    args = parser.parse_args(argv)
    only = set(args.only.split(",")) if args.only else None
    rows = []
    start = time.perf_counter()
    for name, module in _modules(only):
        print(f"[bench] {name} ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        takes_quick = "quick" in inspect.signature(module.run).parameters
        for row in (module.run(quick=args.quick) if takes_quick else module.run()):
            rows.append({"benchmark": name, **row})
        print(f"[bench] {name} done in {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
    total = time.perf_counter() - start
    budget = QUICK_BUDGET_S if args.quick else FULL_BUDGET_S
    if only is None:
        rows.append({"benchmark": "run", "name": f"whole {'quick ' if args.quick else ''}benchmark run, wall time",
                     "value": total, "unit": "s", "target": budget, "ok": total <= budget})
    header = f"{'benchmark':<14} {'name':<56} {'value':>12} {'unit':<10} {'target':>10}  ok"
    print(header)
    print("-" * len(header))
    for r in rows:
        target = r.get("target")
        ok = r.get("ok")
        print(
            f"{r['benchmark']:<14} {r['name']:<56} {r['value']:>12.4g} {r['unit']:<10} "
            f"{_target(target):>10}  {'' if ok is None else ('yes' if ok else 'NO')}"
        )
    if args.json:
        atomic_write_json(
            args.json,
            {"machine": {"python": platform.python_version(), "processor": platform.machine()},
             "mode": "quick" if args.quick else "full", "rows": rows},
        )
        print(f"wrote {args.json}", file=sys.stderr)
    return 0 if all(r.get("ok", True) for r in rows) else 1


def _target(target) -> str:
    """Numbers with 4 significant digits; text targets (e.g. '<= 1.05') as given."""
    if target is None or target == "":
        return ""
    return target if isinstance(target, str) else f"{target:.4g}"


if __name__ == "__main__":
    sys.exit(main())
