"""``nniquad bound``: the time-optimal lower bound on settling under the tilt limit."""

from __future__ import annotations

import argparse

from nniquad.analysis.bound import time_optimal_bound
from nniquad.cli.commands.common import (
    add_json_option,
    add_tilt_limit_option,
    add_vehicle_option,
    add_xi0_option,
    vehicle_from_args,
    write_json_if_asked,
)

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run"]

HELP = "time-optimal lower bound on settling under the tilt limit"
DESCRIPTION = """Time-optimal lower bound on horizontal settling under the tilt limit.

Holding altitude at tilt T gives a horizontal acceleration of g tan(T), so the
tilt limit caps it at a_max = g tan(tilt limit) (or lower, if full thrust
cannot hold altitude at that tilt).  Starting at rest at xi0, the minimum time
into the settling band (radius 2 % of |xi0|) is computed with CasADi/IPOPT
for two cases, and checked against the straight-line bang-bang closed form:

  rest_to_rest  the vehicle ends at rest inside the band;
  enter_band    the vehicle enters the band at a speed from which braking at
                a_max stops it inside the band.  This matches the settling
                definition (last exit from the band): no controller within the
                tilt limit can settle faster.

Tuning results are reported as a ratio to enter_band_s (1.0 would be the
physical limit)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_vehicle_option(parser)
    add_tilt_limit_option(parser)
    add_xi0_option(parser)
    add_json_option(parser, "bounds, closed forms, solver statistics and optimal trajectories")


def run(args: argparse.Namespace) -> int:
    vehicle = vehicle_from_args(args)
    res = time_optimal_bound(vehicle, xi0=tuple(args.xi0), tilt_limit_deg=args.tilt_limit)
    print(f"vehicle: {vehicle.name}")
    rows = [
        ("initial distance |xi0|", res.distance_m, "m"),
        ("settling band radius", res.band_radius_m, "m"),
        ("tilt limit (requested)", res.tilt_limit_deg, "deg"),
        ("tilt limit (thrust, altitude hold)", res.thrust_tilt_limit_deg, "deg"),
        ("max horizontal acceleration", res.a_max_m_s2, "m/s^2"),
        ("rest_to_rest (IPOPT)", res.rest_to_rest_s, "s"),
        ("rest_to_rest (closed form)", res.rest_to_rest_closed_form_s, "s"),
        ("enter_band (IPOPT)", res.enter_band_s, "s"),
        ("enter_band (closed form)", res.enter_band_closed_form_s, "s"),
    ]
    print(f"{'quantity':<36} {'value':>12}  unit")
    for name, value, unit in rows:
        print(f"{name:<36} {value:>12.6g}  {unit}")
    print(
        f"IPOPT vs closed form (relative): rest_to_rest {res.rest_to_rest_rel_error:.2e}, "
        f"enter_band {res.enter_band_rel_error:.2e} ({res.n_intervals} intervals)"
    )
    write_json_if_asked(args, res.to_json())
    return 0
