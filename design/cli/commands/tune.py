"""``nniquad tune``: the fastest gain set the NI theory certifies."""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Any

from .common import add_json_option, add_vehicle_option, vehicle_from_args, write_json_if_asked

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run", "add_tuning_options", "tune_options_from_args",
           "Progress", "print_tune_result"]

HELP = "find the fastest gain set the NI theory certifies"
DESCRIPTION = """Find the gain set (kp, Gamma, delta) with the shortest settling time.

Constraints: the sector bound delta >= 1/(gamma_max m kp) (paper: gamma_max =
0.8), the tilt limit (commanded, and on the full model the actual tilt within
the limit + 1 deg), the rotor-speed limits, and by default a certified reach:
the region-of-attraction LMI under tilt saturation must certify every
displacement from rest up to --roa-radius (default |xi0| = 2.5 m of the
paper's run; 0 switches this off).  On the full model the attitude loop
(natural frequency, damping, and the deceleration of its square-root error
shaping) is tuned with the gains.

Method: a scrambled Sobol sweep in the coordinates (ln kp, u = ln(gamma_max m
kp delta) >= 0, ln Gamma delta [, attitude]), every point simulated in one
CasADi batch, then a batched direct search with random orthogonal poll bases
from the best distinct points; all of it rerun from other seeds to show the
optimum is not a grid artefact.  Settling times are reported as a ratio to
the time-optimal bound (nniquad bound)."""


def add_tuning_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by ``tune`` and ``certify``."""
    from nniquad.tuning.tune import BUDGETS, DEFAULT_ROA_RADIUS_M

    parser.add_argument("--model", choices=("reduced", "full"), default="reduced",
                        help="model the settling time is measured on (default reduced)")
    parser.add_argument("--gamma-max", type=float, default=0.8, metavar="G",
                        help="gamma_max of the sector bound, in (0, 1) (default 0.8, the paper's)")
    parser.add_argument("--roa-radius", type=float, default=DEFAULT_ROA_RADIUS_M, metavar="R",
                        help=f"certified reach required in m (default {DEFAULT_ROA_RADIUS_M:g}; 0: off)")
    parser.add_argument("--mass-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                        help="true masses in kg the settling time must hold for (worst case is tuned)")
    parser.add_argument("--noise", type=float, default=0.0, metavar="SIGMA",
                        help="position-noise standard deviation in m during tuning (default 0)")
    parser.add_argument("--tilt-limit", type=float, default=30.0, metavar="DEG", help="tilt limit in deg (default 30)")
    parser.add_argument("--budget", choices=tuple(BUDGETS), default="normal",
                        help="search effort (default normal; quick for a fast look)")
    parser.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the sweep and the search (default 0)")
    parser.add_argument("--reruns", type=int, default=None, metavar="K",
                        help="extra seeds for the grid-artefact check (default: the budget's)")
    parser.add_argument("--margin", action="store_true",
                        help="full model: also demand the settling time with 1.5x the motor time constant and "
                             "2 mm position noise (a more robust, slower design)")
    add_vehicle_option(parser)


def tune_options_from_args(args: argparse.Namespace):
    from nniquad.tuning.tune import TuneOptions

    return TuneOptions(model=args.model, gamma_max=args.gamma_max, roa_radius_m=args.roa_radius,
                       mass_range=None if args.mass_range is None else tuple(args.mass_range),
                       noise_sigma_m=args.noise, tilt_limit_deg=args.tilt_limit, budget=args.budget,
                       seed=args.seed, reruns=args.reruns, margin=args.margin)


class Progress:
    """Status lines on stderr with the elapsed time (one per message, rate-limited on long runs)."""

    def __init__(self, label: str, every_s: float = 1.0) -> None:
        self.label, self.every_s = label, every_s
        self.t0 = time.perf_counter()
        self.last = -math.inf

    def __call__(self, message: str) -> None:
        now = time.perf_counter() - self.t0
        if now - self.last >= self.every_s or "sweep" in message:
            print(f"[{self.label} {now:6.1f} s] {message}", file=sys.stderr, flush=True)
            self.last = now


def _fmt(x: Any, digits: int = 5) -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    return f"{x:.{digits}g}"


def print_tune_result(res) -> None:
    """The tuned gains and their numbers, with units."""
    m = res.metrics
    rows = [
        ("model", res.options.model, ""),
        ("kp", _fmt(res.gains.kp), "1/s^2"),
        ("Gamma", _fmt(res.gains.Gamma), "-"),
        ("delta", _fmt(res.gains.delta), "-"),
        ("smallest gamma (sector)", _fmt(res.gamma), f"<= gamma_max {res.options.gamma_max:g}"),
    ]
    if res.options.dims > 3:
        rows += [("attitude natural frequency", _fmt(res.inner.attitude_wn_rad_s), "rad/s"),
                 ("attitude damping", _fmt(res.inner.attitude_zeta), "-"),
                 ("attitude deceleration (shaping)", _fmt(res.inner.attitude_accel_limit_rad_s2), "rad/s^2")]
    rows += [
        ("settling time (worst scenario)", _fmt(res.settling_s), "s"),
        ("time-optimal bound enter_band_s", _fmt(res.bound.enter_band_s), "s"),
        ("ratio to bound", _fmt(res.ratio_to_bound, 4), "-"),
        ("overshoot", _fmt(m.overshoot_pct, 3), "%"),
        ("peak actual tilt", _fmt(m.peak_tilt_deg, 4), "deg"),
        ("peak rotor speed", _fmt(m.peak_rotor_speed_rad_s, 4), "rad/s"),
        ("certified reach (ROA LMI)", _fmt(res.certified_reach_m, 4), f"m (required {res.roa_radius_m:g})"),
        ("best settling per seed", ", ".join(f"{r['seed']}: {r['settling_s']:.4g}" for r in res.reruns), "s"),
        ("simulations / LMI solves", f"{res.n_simulations} / {res.n_lmi}", ""),
        ("time taken", _fmt(res.elapsed_s, 3), "s"),
    ]
    w = max(len(r[0]) for r in rows)
    for name, value, unit in rows:
        print(f"{name:<{w}}  {value}  {unit}".rstrip())


def run(args: argparse.Namespace) -> int:
    from nniquad.tuning.tune import tune

    vehicle = vehicle_from_args(args)
    options = tune_options_from_args(args)
    res = tune(vehicle, options, progress=Progress("tune"))
    print_tune_result(res)
    write_json_if_asked(args, res.to_json())
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_tuning_options(parser)
    add_json_option(parser, "tuned gains, metrics, per-seed optima and search statistics")
