"""``nniquad lmi``: the NI / SNI lemmas, closed-loop, robust and saturated LMIs, with cross-checks."""

from __future__ import annotations

import argparse
import math

import numpy as np

from nniquad.config import XI0_M

from .common import add_json_option, add_vehicle_option, finite_positive, vehicle_from_args, write_json_if_asked

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
axis), the controller LMIs to C(s) = Gamma/(s + Gamma delta).  Next to the
LMIs the command prints the definition-level frequency-domain NI/SNI checks,
the exact Routh condition m kp delta > 1, the smallest sector gamma and the
closed-loop poles, as independent cross-checks.

Defaults: the paper's gains (kp = 5, Gamma = 160, delta = 0.6), the paper's
vehicle, mass range [0.8 m, 1.2 m], tilt limit 30 deg.  The saturation is
modelled per axis at g tan(tilt)/sqrt(2), which keeps the total tilt inside
the limit (conservative for the norm limit)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--kp", default="5.0", metavar="K", help="inner-loop gain kp (x axis), 1/s^2 (default 5)")
    parser.add_argument("--kpy", default=None, metavar="K", help="inner-loop gain of the y axis (default: = kp)")
    parser.add_argument("--Gamma", default="160.0", metavar="G", help="controller gain Gamma (default 160)")
    parser.add_argument("--delta", default="0.6", metavar="D", help="controller parameter delta (default 0.6)")
    parser.add_argument("--tilt-limit-deg", default="30.0", metavar="DEG", help="total tilt limit in degrees (default 30)")
    parser.add_argument(
        "--mass-range", nargs=2, default=None, metavar=("LO", "HI"),
        help="true-mass interval in kg for the robust LMIs (default: 0.8 m to 1.2 m of the vehicle)",
    )
    add_vehicle_option(parser)
    add_json_option(parser, "LMI results")


def _gains(args: argparse.Namespace):
    from nniquad.control.gains import Gains

    kpy = None if args.kpy is None else finite_positive("kpy", args.kpy)
    return Gains(
        kp=finite_positive("kp", args.kp),
        Gamma=finite_positive("Gamma", args.Gamma),
        delta=finite_positive("delta", args.delta),
        kpy=kpy,
    )


#: The paper's initial horizontal position (m), at rest (DESIGN.md conventions).
PAPER_START = XI0_M

_UNITS = {
    "ni_lemma_paper": "min eig P",
    "ni_lemma_dissipation": "min eig P",
    "ni_lemma_lanzon_petersen": "min eig Y",
    "sni_lemma": "-max eig(AY+YA')",
    "ni_dissipation_strict": "eta",
    "closed_loop_decay": "eps 1/s",
    "robust_mass_decay": "eps 1/s",
    "region_of_attraction": "r m",
}


def run(args: argparse.Namespace) -> int:
    from nniquad.errors import GainError
    from nniquad.analysis.linear import ReducedLoop
    from nniquad.analysis.lmi import reach_of, run_all, start_certified
    from nniquad.config import MASS_RANGE_FRACTION

    gains = _gains(args)
    vehicle = vehicle_from_args(args)
    m, g = vehicle.m, vehicle.g
    tilt = finite_positive("tilt-limit-deg", args.tilt_limit_deg)
    if args.mass_range is None:
        mass_range = (MASS_RANGE_FRACTION[0] * m, MASS_RANGE_FRACTION[1] * m)
    else:
        lo, hi = (finite_positive("mass-range", v) for v in args.mass_range)
        if lo > hi:
            raise GainError(f"mass-range LO must not exceed HI, got {lo} > {hi}")
        mass_range = (lo, hi)
    loop = ReducedLoop.from_vehicle(vehicle, gains)
    results = run_all(loop, mass_range=mass_range, tilt_limit_deg=tilt)

    kpx, kpy = gains.axes()
    print(f"vehicle {vehicle.name}: m = {m:g} kg, g = {g:g} m/s^2")
    print(f"gains: kp_x = {kpx:g}, kp_y = {kpy:g} 1/s^2, Gamma = {gains.Gamma:g}, delta = {gains.delta:g}")
    print()
    header = f"{'LMI':<42} {'feasible':<8} {'status':<18} {'margin':>11}  {'(meaning)':<18} key values"
    print(header)
    print("-" * len(header))
    for r in results:
        base = r.name.split("[")[0]
        margin = "-" if not math.isfinite(r.margin) else f"{r.margin:.5g}"
        keys = []
        for k in ("decay_rate_poles", "decay_rate_poles_pointwise_min", "m_min_exact", "max_displacement_m", "u0"):
            if k in r.values:
                keys.append(f"{k}={r.values[k]:.4g}")
        for k in ("P", "Y"):
            M = r.matrices.get(k)
            if M is not None and M.shape[0] <= 2:
                keys.append(f"{k}={np.array2string(M, precision=5, suppress_small=True, separator=',').replace(chr(10), '')}")
        if "ni_dissipation_max_eig" in r.residuals and r.feasible:
            keys.append(f"NI dissipation of this P: max eig {r.residuals['ni_dissipation_max_eig']:+.3g}")
        print(f"{r.name:<42} {'yes' if r.feasible else 'NO':<8} {r.status:<18} {margin:>11}  {_UNITS.get(base, ''):<18} {' '.join(keys)}")

    # ---- independent cross-checks
    from nniquad.analysis.frequency import ni_check, ni_interconnection_check

    pd = loop.poles_and_damping()
    print()
    print("cross-checks")
    product = loop.margin_product
    print(f"  Routh: m kp delta = {product:.4g} (stable iff > 1); smallest sector gamma = "
          f"{loop.smallest_gamma:.4g} (paper needs < 1)")
    slow = pd.poles[0]
    print(f"  poles (python-control): max Re = {pd.max_real_part:.4g} 1/s, min damping = {pd.min_damping:.4g}, "
          f"slowest pair {slow.real:.4g} +/- {abs(slow.imag):.4g}j; -2 max Re = {pd.decay_rate:.4g} 1/s")
    freq_json = {}
    for label, _ in loop.axes:
        ic = ni_interconnection_check(loop.plant_ss(label), loop.controller_ss())
        res = ", ".join(f"K0({w:.4g} rad/s) = {K.real.ravel()[0]:.4g}" for w, K in ic.plant.residues)
        print(f"  frequency [{label}]: plant NI={ic.plant.is_ni} SNI={ic.plant.is_sni} ({res}); "
              f"controller NI={ic.controller.is_ni} SNI={ic.controller.is_sni}; G(0)C(0) = {ic.dc_loop_gain:.4g}; "
              f"NI theorem predicts stable={ic.predicted_stable}, poles stable={ic.poles_stable}")
        freq_json[label] = {
            "plant_ni": ic.plant.is_ni, "plant_sni": ic.plant.is_sni,
            "plant_residues": [[w, float(K.real.ravel()[0])] for w, K in ic.plant.residues],
            "controller_ni": ic.controller.is_ni, "controller_sni": ic.controller.is_sni,
            "dc_loop_gain": ic.dc_loop_gain, "predicted_stable": ic.predicted_stable, "poles_stable": ic.poles_stable,
        }
    roa = [r for r in results if r.name.startswith("region_of_attraction")]
    if roa:
        ok = start_certified(roa, PAPER_START)
        how = ("norm limit, rotation-invariant ellipsoid" if len(roa) == 1
               else "per-axis inscribed limit")
        print(f"  region of attraction: displacement from rest up to {reach_of(roa):.4g} m certified "
              f"({how}, u0 = {roa[0].values.get('u0', float('nan')):.4g} m/s^2); the paper's start (2, -1.5) m is "
              f"{'inside' if ok else 'NOT inside'} the certified set")

    write_json_if_asked(args, {
        "vehicle": vehicle.name,
        "m": m,
        "g": g,
        "gains": gains.as_dict(),
        "mass_range": list(mass_range),
        "tilt_limit_deg": tilt,
        "lmis": [r.to_json() for r in results],
        "frequency": freq_json,
        "poles": {"real": pd.poles.real.tolist(), "imag": pd.poles.imag.tolist(), "min_damping": pd.min_damping},
    })
    return 0
