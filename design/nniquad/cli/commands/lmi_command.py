"""``nniquad lmi``: the NI / SNI lemmas, closed-loop, robust and saturated LMIs, with cross-checks."""

from __future__ import annotations

import argparse

from nniquad.cli.commands.common import (
    add_controller_option,
    add_gain_options,
    add_json_option,
    add_tilt_limit_option,
    add_vehicle_option,
    finite_positive,
    law_gains,
    vehicle_from_args,
    write_json_if_asked,
)
from nniquad.errors import VehicleError
from nniquad.laws.registry import law_named, ni_law_names
from nniquad.validate import finite_number

HELP = "solve the NI, SNI, closed-loop and region-of-attraction LMIs"
DESCRIPTION = """Solve every LMI of the reduced horizontal loop with Clarabel and re-check each
answer with numpy:

  ni_lemma_paper            the paper's Lemma (P>0, PA+A'P<=0, PB=C')
  ni_lemma_dissipation      NI lemma as the NI literature states it (dV/dt <= ydot'u)
  ni_lemma_lanzon_petersen  the Lanzon-Petersen (2008) form (Y>0, AY+YA'<=0, B+AYC'=0)
  sni_lemma                 its strict version (AY+YA'<0)
  ni_dissipation_strict     strict dissipation of the whole (x, u) block
  closed_loop_decay         P>0, A'P+PA <= -eps P, largest eps (1/s)
  robust_mass_decay         the same for every true mass in --mass-range
                            (one common P, and a mass-dependent P(1/m))
  region_of_attraction      ellipsoid certified under the tilt limit
                            (generalised sector condition), largest
                            initial displacement from rest (m)

The plant LMIs are applied to the reshaped plant m xi'' + m kp xi = F (per
axis), the controller LMIs to the law's C(s) (the paper's: Gamma/(s + Gamma delta);
--controller sni2: k/(s^2 + 2 zeta omega s + omega^2)).  Next to the
LMIs the command prints the definition-level frequency-domain NI/SNI checks,
the exact Routh condition m kp delta > 1, the smallest sector gamma and the
closed-loop poles, as independent cross-checks.

Defaults: the paper's gains (kp = 5, Gamma = 160, delta = 0.6), the paper's
vehicle, mass range [0.8 m, 1.2 m], tilt limit 30 deg.  The saturation is
modelled per axis at g tan(tilt)/sqrt(2), which keeps the total tilt inside
the limit (conservative for the norm limit)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_controller_option(parser, ni_law_names(), "nni", "law of the NI structure")
    add_gain_options(parser.add_argument_group("gains (default: the paper's, for the nni law)"), ni_law_names())
    add_tilt_limit_option(parser)
    parser.add_argument(
        "--mass-range", nargs=2, default=None, metavar=("LO", "HI"),
        help="true-mass interval in kg for the robust LMIs (default: 0.8 m to 1.2 m of the vehicle)",
    )
    add_vehicle_option(parser)
    add_json_option(parser, "LMI results")


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.analysis.lmi.overview import lmis

    gains = law_gains(args, law_named(args.controller))
    mass_range = None
    if args.mass_range is not None:
        mass_range = tuple(finite_number("mass-range", v, error=VehicleError, positive=True) for v in args.mass_range)
        if mass_range[0] > mass_range[1]:
            raise VehicleError(f"mass-range LO must not exceed HI, got {mass_range[0]} > {mass_range[1]}")
    tilt = finite_positive("tilt-limit", args.tilt_limit)
    report = lmis(vehicle_from_args(args), gains, mass_range=mass_range, tilt_limit_deg=tilt)
    print(report.table())
    write_json_if_asked(args, report.to_json())
    return 0
