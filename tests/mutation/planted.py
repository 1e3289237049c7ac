"""Planted bugs the suite must kill (``make planted``).

Seven realistic bugs were found that the whole suite let pass; the faster
suite must still kill them.  Each entry below plants one of
them, as a one-line edit of the source, in a staged copy of the package
(``build/planted/<name>/nniquad``, the same layout as ``make mutation``), then
runs the test files that are meant to catch it with that copy first on
``sys.path`` (and on ``PYTHONPATH`` for the subprocesses the tests start).
The bug counts as killed when at least one of those tests fails; the planted
source line is checked to exist first, so an edit of the code that moves the
line is reported as a stale entry (exit 2), never as a kill.

Exit status: 0 every planted bug is killed, 1 one survives, 2 a stale entry or
a bad option.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BUILD = ROOT / "build" / "planted"


@dataclass(frozen=True)
class Planted:
    """One planted bug: replace ``old`` by ``new`` (exactly once) in ``file`` (relative to the package)."""

    name: str
    what: str
    file: str
    old: str
    new: str
    tests: tuple[str, ...]


PLANTED: tuple[Planted, ...] = (
    Planted("sector-accepts-gamma-one", "the sector bound accepts gamma = 1 exactly ('< 1' became '<= 1')",
            "analysis/reduced_loop.py", "return self.smallest_gamma < 1.0", "return self.smallest_gamma <= 1.0",
            ("tests/test_linear.py",)),
    Planted("verify-ni-checks-p-only", "verify's NI checks test only P > 0, not the dissipation inequality",
            "certificates/recheck_reduced_loop.py",
            "    proofs = V.definite(P if stated_P is None else stated_P, exact=True) + dissipation\n"
            "    return proof_check(name, worst <= tol,",
            "    proofs = V.definite(P if stated_P is None else stated_P, exact=True)\n"
            "    return proof_check(name, True,",
            ("tests/test_certificate.py",)),
    Planted("smooth-response-or", "the simulation claim's smoothness holds if any one of its conditions holds",
            "proofs/simulation.py", "            and shape[\"zero crossings along the initial direction\"] == 0\n"
            "            and shape[\"local extrema (oscillations)\"] == 0)",
            "            or shape[\"zero crossings along the initial direction\"] == 0\n"
            "            or shape[\"local extrema (oscillations)\"] == 0)",
            ("tests/test_proofs_simulation.py",)),
    Planted("overshoot-past-the-origin", "overshoot measured as the distance past the origin, not along the start "
            "direction", "sim/metrics.py", "past = np.maximum(np.max(-proj, axis=1), 0.0)",
            "past = np.maximum(np.max(np.where(proj < 0, np.hypot(a[..., 0], a[..., 1]), 0.0), axis=1), 0.0)",
            ("tests/test_metrics.py",)),
)


def stage(bug: Planted) -> Path:
    """A copy of the package with ``bug`` planted; returns the folder to put first on ``sys.path``."""
    root = BUILD / bug.name
    shutil.rmtree(root, ignore_errors=True)
    pkg = root / "nniquad"
    shutil.copytree(ROOT / "design" / "nniquad", pkg, ignore=shutil.ignore_patterns("__pycache__"))  # proofs link followed
    target = pkg / bug.file
    source = target.read_text()
    if source.count(bug.old) != 1:
        raise LookupError(f"{bug.name}: the line to plant occurs {source.count(bug.old)} times in {bug.file}, not once")
    target.write_text(source.replace(bug.old, bug.new))
    return root


def run(bug: Planted, jobs: int) -> tuple[bool, float, str]:
    """Plant ``bug``, run its tests; ``(killed, seconds, last line of pytest)``."""
    root = stage(bug)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep),
               MPLBACKEND="Agg")
    probe = subprocess.run([sys.executable, "-c", "import nniquad; print(nniquad.__file__)"], env=env,
                           capture_output=True, text=True, cwd=ROOT)
    if not probe.stdout.strip().startswith(str(root)):
        raise RuntimeError(f"{bug.name}: the staged copy is not the one imported ({probe.stdout.strip()})")
    args = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *bug.tests]
    if jobs > 1:
        args += ["-n", str(jobs)]
    t0 = time.perf_counter()
    out = subprocess.run(args, env=env, capture_output=True, text=True, cwd=ROOT)
    lines = [ln for ln in out.stdout.splitlines() if ln.strip()]
    return out.returncode == 1, time.perf_counter() - t0, lines[-1] if lines else out.stderr.strip()[-200:]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="planted", description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", action="append", choices=[b.name for b in PLANTED],
                        help="run this planted bug only (repeatable; default: all)")
    parser.add_argument("--jobs", type=int, default=1, help="pytest-xdist workers per run (default 1)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error("--jobs must be at least 1")
    survived = 0
    print(f"{'planted bug':<28} {'killed':>6} {'time [s]':>9}  pytest")
    for bug in PLANTED:
        if args.only and bug.name not in args.only:
            continue
        try:
            killed, seconds, last = run(bug, args.jobs)
        except LookupError as exc:
            print(f"planted: error: {exc}", file=sys.stderr)
            return 2
        survived += not killed
        print(f"{bug.name:<28} {'yes' if killed else 'NO':>6} {seconds:9.1f}  {last}")
    return 1 if survived else 0


if __name__ == "__main__":
    sys.exit(main())
