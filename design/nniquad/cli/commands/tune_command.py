"""``nniquad tune``: the fastest gain set the NI theory certifies."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from nniquad.cli.commands.common import (
    add_controller_option,
    add_delay_option,
    delay_samples,
    add_integral_option,
    add_json_option,
    add_tilt_limit_option,
    add_vehicle_option,
    apply_integral,
    vehicle_from_args,
    write_json_if_asked,
)
from nniquad.cli.commands.reference_options import add_reference_options, reference_settings, tracking_window
from nniquad.config import (
    CONTROL_RATE_HZ,
    DT_S,
    GAMMA_MAX,
    REQUIRED_GM_DB,
    REQUIRED_PM_DEG,
    ROBUST_DELAY_SAMPLES,
    TUNING_SCENARIO_SEED,
    WIND_WEIGHT_FRACTION_RANGE,
)
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import CertificateError, NniquadError
from nniquad.format import fmt, margin_text, margin_verdict
from nniquad.io import parse_data, read_text_file
from nniquad.laws.base import field_unit
from nniquad.laws.classes import DEFAULT_LAW_CLASS, LAW_CLASSES, within_sector_bound
from nniquad.laws.registry import law_named, law_names
from nniquad.progress import Progress

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run", "add_tuning_options", "tune_options_from_args",
           "print_tune_result"]

HELP = "find the fastest gain set the NI theory certifies"
DESCRIPTION = """Find the gain set (kp, Gamma, delta) with the shortest settling time.

Constraints: the law class (--law-class): 'paper' (default) keeps the sector
bound delta >= 1/(gamma_max m kp) (paper: gamma_max = 0.8) and Theorem
main_result certifies the design; 'cascade' drops it, the sampled-data
cascade certificate alone certifies the design (every filtered-derivative PD
law is an NNI law of this class).  Then the tilt limit (commanded, and on the full model the actual tilt within
the limit + 1 deg), the rotor-speed limits, and by default a certified reach:
the region-of-attraction LMI under tilt saturation must certify every
displacement from rest up to --roa-radius (default |xi0| = 2.5 m of the
paper's run; 0 switches this off).  On the full model the attitude loop
(natural frequency, damping, and the deceleration of its square-root error
shaping) is tuned with the gains.

On the full model every candidate runs as it flies: the position sampled at
--rate and the law in discrete time (what the certificate certifies and
'nniquad export' writes).  --warm-start FILE seeds the search with the design
of a 'tune --json' file or a certificate (a filtered PD seeds the NNI law
through its image: kp' = k_p + k_d/tau_f, Gamma = m k_d/tau_f^2, delta =
tau_f/(m k_d)), so the result is never slower than that design in the class.

Method: a scrambled Sobol sweep in the coordinates (ln kp, u = ln(gamma_max m
kp delta) >= 0 [cascade: v = ln(m kp delta - 1)], ln Gamma delta [, attitude]), every point simulated in one
CasADi batch, then a global optimiser from the best distinct points, fed
with batches of candidates: BIPOP-CMA-ES (default) or NOMAD 4's mesh
adaptive direct search (--optimizer nomad, needs PyNomadBBO); all of it
rerun from other seeds to show the optimum is not a grid artefact.  Settling times are reported as a ratio to
the time-optimal bound (nniquad bound).

Tracking objective (--reference SPEC, a waypoint file, circle:R,T or
figure8:AX,AY,T; --feedforward, --feedforward-lead, --tracking-window):
minimise the RMS tracking error over the window of the nominal run started
on the reference with its velocity, subject to every constraint above, the
settling objective's cost included (the design still settles from the
standard start, every robust scenario on the full model); a lost tracking
run is inadmissible.  The objective is printed in words (docs/tuning.md)."""


def add_tuning_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by ``tune`` and ``certify``."""
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.tuning.tune import BUDGETS, DEFAULT_OPTIMIZER, DEFAULT_ROA_RADIUS_M, OPTIMIZERS

    parser.add_argument("--model", choices=("reduced", "full"), default="reduced",
                        help="model the settling time is measured on (default reduced)")
    add_integral_option(parser)
    parser.add_argument("--gamma-max", type=float, default=GAMMA_MAX, metavar="G",
                        help=f"gamma_max of the sector bound, in (0, 1) (default {GAMMA_MAX:g}, the paper's)")

    parser.add_argument("--law-class", choices=tuple(LAW_CLASSES), default=None,
                        help=f"class of certified NNI designs: paper (the sector bound holds; Theorem main_result) or "
                             f"cascade (no sector bound; the sampled-data cascade certificate alone) (default "
                             f"{DEFAULT_LAW_CLASS} for the NNI law; for --controller pd_filtered: only the filtered PDs "
                             "whose NNI image lies in the class)")
    parser.add_argument("--roa-radius", type=float, default=None, metavar="R",
                        help=f"certified reach of the reduced loop's region-of-attraction LMI required in m (default "
                             f"{DEFAULT_ROA_RADIUS_M:g} in the paper class, 0 (off) in the cascade class)")
    parser.add_argument("--rate", type=float, default=None, metavar="HZ",
                        help=f"control rate in Hz (default {CONTROL_RATE_HZ:g}), a period of whole 1 ms steps: full-model "
                             "candidates run the law in discrete time at it; certify computes its margins, cascade "
                             "section and full reference run at it")
    parser.add_argument("--warm-start", action="append", default=[], metavar="FILE",
                        help="seed the search with the gains and inner loops of a 'tune --json' file or a certificate "
                             "(repeatable; a filtered PD seeds the NNI law through its image)")
    parser.add_argument("--mass-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                        help="true masses in kg the settling time must hold for (worst case is tuned)")
    parser.add_argument("--noise", type=float, default=0.0, metavar="SIGMA",
                        help="position-noise standard deviation in m during tuning (default 0)")
    add_tilt_limit_option(parser)
    parser.add_argument("--budget", choices=tuple(BUDGETS), default="normal",
                        help="search effort (default normal; quick for a fast look; with the robust objective "
                             "the sni2 law's normal is the thorough search without its extra seeds: at the NNI "
                             "law's normal its optimum depended on the seed, docs/notes/laws.md)")
    parser.add_argument("--optimizer", choices=OPTIMIZERS, default=DEFAULT_OPTIMIZER,
                        help=f"optimiser after the sweep: cma (BIPOP-CMA-ES) or nomad (MADS, NOMAD 4; needs PyNomadBBO) "
                             f"(default {DEFAULT_OPTIMIZER})")
    parser.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the sweep and the search (default 0)")
    parser.add_argument("--reruns", type=int, default=None, metavar="K",
                        help="extra seeds for the grid-artefact check (default: the budget's)")
    parser.add_argument("--margin", action="store_true",
                        help="full model: also demand the settling time with 1.5x the motor time constant and "
                             "2 mm position noise (a more robust, slower design)")
    add_vehicle_option(parser)
    parser.add_argument("--nominal", action="store_true",
                        help="full model: tune on the nominal scenario alone (default for full: the robust "
                             "objective, p95 settling over a fixed set of perturbed scenarios incl. box corners)")
    parser.add_argument("--no-margins", action="store_true",
                        help="full model: do not require GM >= 6 dB both ways at the attitude and horizontal "
                             "break points of the linearised cascade (the margins are still reported)")
    parser.add_argument("--require-pm", action="store_true",
                        help="full model: also rank the shortfall from PM >= 45 deg (out of reach of this law at "
                             "the horizontal break point: the search then trades settling time for a few degrees)")
    parser.add_argument("--scenario-seed", type=int, default=TUNING_SCENARIO_SEED, metavar="N",
                        help=f"seed of the robust tuning scenarios (default {TUNING_SCENARIO_SEED}; a Monte Carlo "
                             "study of the result should use another seed)")
    parser.add_argument("--scenario-noise-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                        help="position-noise standard deviations in m of the robust tuning scenarios: the box corners "
                             "take HI, the random draws U[LO, HI], one draw per position sample at --rate (default "
                             "0 0.02, the Monte Carlo study's; set it to your sensor's: a velocity-free law "
                             "differentiates the position, so the noise it must tolerate limits its speed)")
    parser.add_argument("--scenario-wind-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                        help="constant wind force of the robust tuning scenarios as a fraction of m g: the box "
                             "corners take HI, pushing against the return, the random draws U[LO, HI] (default "
                             f"{WIND_WEIGHT_FRACTION_RANGE[0]:g} {WIND_WEIGHT_FRACTION_RANGE[1]:g}, the Monte Carlo "
                             "study's)")
    add_delay_option(parser, None, "in the robust objective's perturbed scenarios (default "
                                   f"{ROBUST_DELAY_SAMPLES}, the robust default; the nominal run has none); certify "
                                   "also certifies the cascade with it (default "
                                   f"{ROBUST_DELAY_SAMPLES})")


def tune_options_from_args(args: argparse.Namespace):
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.sim.options import check_rate_hz
    from nniquad.tuning.tune import TuneOptions

    # before any work: a bad rate fails at once
    rate = check_rate_hz(CONTROL_RATE_HZ if args.rate is None else args.rate, DT_S, error=NniquadError)
    apply_integral(args)
    controller = getattr(args, "controller", "nni")  # certify: its own --controller (an NI law)
    law = law_named(controller)
    # the class the design is tuned in: the stated one, else the law's first (an integral law: cascade)
    in_class = law.in_class(args.law_class if args.law_class is not None else law.law_classes[0])
    robust = not (args.nominal or args.model != "full")
    for option, value in (("--scenario-noise-range", args.scenario_noise_range),
                          ("--scenario-wind-range", args.scenario_wind_range)):
        if value is not None and not robust:
            raise NniquadError(f"{option} sets the robust objective's scenarios: it needs --model full without "
                               "--nominal")
    follow = tracking_settings(args)
    return TuneOptions(**follow, model=args.model, gamma_max=args.gamma_max, roa_radius_m=args.roa_radius,
                       law_class=args.law_class, rate_hz=rate,
                       mass_range=None if args.mass_range is None else tuple(args.mass_range),
                       noise_sigma_m=args.noise, tilt_limit_deg=args.tilt_limit, budget=args.budget,
                       seed=args.seed, reruns=args.reruns, margin=args.margin,
                       objective="robust" if robust else "nominal",
                       require_margins=args.model == "full" and not args.no_margins and in_class,
                       require_pm=args.require_pm and not args.no_margins,
                       scenario_seed=args.scenario_seed, controller=controller,
                       scenario_noise_range_m=(None if args.scenario_noise_range is None
                                               else tuple(args.scenario_noise_range)),
                       scenario_wind_fraction_range=(None if args.scenario_wind_range is None
                                                     else tuple(args.scenario_wind_range)),
                       optimizer=args.optimizer, delay_samples=delay_samples(args) if robust else None)


def tracking_settings(args: argparse.Namespace) -> dict:
    """The :class:`~nniquad.tuning.tune_options.TuneOptions` fields of ``--reference``, ``--feedforward``,
    ``--feedforward-lead`` and ``--tracking-window`` (empty without ``--reference``; ``certify`` has none).

    Parameters
    ----------
    args
        The parsed options.
    """
    if not hasattr(args, "reference"):
        return {}
    follow = reference_settings(args)  # one-line errors: a bad spec, a flag without --reference
    if not follow:
        return {}
    return {"reference": follow["reference"], "feedforward": follow["feedforward"],
            "feedforward_lead_s": follow["feedforward_lead_s"], "tracking_window": tracking_window(args)}


def warm_starts_from_args(args: argparse.Namespace) -> list:
    """The ``(gains, inner loops)`` of every ``--warm-start`` file (:func:`designs_from_files`)."""
    return designs_from_files(getattr(args, "warm_start", None) or [], "--warm-start")


def designs_from_files(paths, option: str, records: list | None = None) -> list:
    """The ``(gains, inner loops)`` of ``tune --json`` files or certificates (the law is the file's).

    Parameters
    ----------
    paths
        The files.
    option
        The option that named them, for the messages.
    records
        When given, the record of the tune behind each file is appended to it: a
        certificate's ``tuning`` section, or the ``tune --json`` document itself.

    Raises
    ------
    NniquadError
        A file that is neither (one line naming it).
    """
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.certificate import certificate_gains, certificate_inner_loop, check_form

    out = []
    for path in paths:
        data = parse_data(read_text_file(Path(path), what=option), "json", where=f"{option} {path}")
        try:
            if isinstance(data, dict) and data.get("schema") is not None:  # a certificate (digest checked)
                check_form(data, str(path))
                out.append((certificate_gains(data), certificate_inner_loop(data)))
                if records is not None:
                    records.append(data.get("tuning"))
                continue
            gains = law_named(data["controller"], error=NniquadError).gains(
                {k: v for k, v in data["gains"].items() if v is not None})
            gains = type(gains).from_values(gains.values())  # canonical: a second-axis gain equal to the first
            out.append((gains, InnerLoopGains(**data["inner_loop"])))
            if records is not None:
                records.append(data)
        except (KeyError, TypeError, CertificateError, NniquadError) as exc:
            raise NniquadError(f"{option} {path}: not a 'tune --json' file or a certificate ({exc})") from None
    return out


def print_tune_result(res) -> None:
    """The tuned gains and their numbers, with units."""
    m = res.metrics
    from dataclasses import fields


    rows = [("model", res.options.model, ""), ("controller", res.options.controller, "")]
    rows += [(f.name, fmt(getattr(res.gains, f.name), digits=5), field_unit(f)[0])
             for f in fields(res.gains) if getattr(res.gains, f.name) is not None]
    if res.options.law_class is not None:
        rows.append(("law class", res.options.law_class, "(sector bound " + ("required)" if res.options.law_class
                                                                              == "paper" else "dropped)")))
    law = res.options.law
    if law.ni_structure:
        rows.append((f"DC loop gain gamma = {law.gamma_formula} (sector)", fmt(res.gamma, digits=5),
                     f"{'<=' if within_sector_bound(res.gamma, res.options.gamma_max) else '>'} gamma_max {res.options.gamma_max:g}"))
    image = res.nni_image()
    if image is not None:
        values = {k: v for k, v in image.items() if k not in ("gamma", "in_class", "controller")}
        rows.append((f"NNI image ({', '.join(values)})", ", ".join(fmt(v, digits=5) for v in values.values()),
                     f"gamma {fmt(image['gamma'], digits=4)}"))
    if res.options.model == "full" and res.options.tune_attitude:
        rows += [("attitude natural frequency", fmt(res.inner.attitude_wn_rad_s, digits=5), "rad/s"),
                 ("attitude damping", fmt(res.inner.attitude_zeta, digits=5), "-"),
                 ("attitude deceleration (shaping)", fmt(res.inner.attitude_accel_limit_rad_s2), "rad/s^2")]
    if res.tracking_rms_m is not None:
        t0, t1 = res.options.tracking_window
        rows += [(f"tracking RMS over [{t0:g}, {t1:g}] s", fmt(res.tracking_rms_m, digits=4), "m"),
                 (f"tracking max over [{t0:g}, {t1:g}] s", fmt(res.tracking_max_m, digits=4), "m")]
    rows += [
        ("settling time" + (f" (p95 of {res.scenario_count} robust scenarios, {_settled_where(res)})"
                            if res.objective == "robust" else " (worst scenario)"), fmt(res.settling_s, digits=5), "s"),
        ("nominal settling time", fmt(res.nominal_settling_s, digits=5), "s"),
        ("time-optimal bound enter_band_s", fmt(res.bound.enter_band_s, digits=5), "s"),
        ("ratio to bound", fmt(res.ratio_to_bound, digits=4), "-"),
        ("overshoot", fmt(m.overshoot_pct, digits=3), "%"),
        ("peak actual tilt", fmt(m.peak_tilt_deg, digits=4), "deg"),
        ("peak rotor speed", fmt(m.peak_rotor_speed_rad_s, digits=4), "rad/s"),
        ("certified reach (ROA LMI)", fmt(res.certified_reach_m, digits=4) if law.ni_structure
         else "none (not a design of the NI structure: no sector bound)", f"m (required {res.roa_radius_m:g})"),
        ("best tracking RMS per seed", ", ".join(f"{r['seed']}: {fmt(r['tracking_rms_m'], digits=4)}"
                                                 for r in res.reruns), "m") if res.options.tracking else
        ("best settling per seed", ", ".join(f"{r['seed']}: {r['settling_s']:.4g}" for r in res.reruns), "s"),
        ("simulations / LMI solves", f"{res.n_simulations} / {res.n_lmi}", ""),
        ("time taken", fmt(res.elapsed_s, digits=3), "s"),
    ]
    if res.objective == "robust":
        lo, hi = res.options.robust_noise_range_m
        rows.append(("robust scenarios' position noise", f"sigma {fmt(lo)} to {fmt(hi)} (corners {fmt(hi)})", "m"))
    if res.worst_scenario is not None:
        rows.append(("worst robust scenario", f"{res.worst_scenario['label']}: {res.worst_scenario['cost_s']:.4g}", "s"))
    for bp, mg in (res.margins or {}).items():
        req = mg.get("required", {"gm_db": REQUIRED_GM_DB, "pm_deg": REQUIRED_PM_DEG})
        rows.append((f"{bp} margins (linearised, 100 Hz)", margin_text(mg["gm_db"], mg["gm_lower_db"], mg["pm_deg"]),
                     margin_verdict(mg, req["gm_db"], req["pm_deg"])))
    if res.margins_met is False:
        rows.append(("margin requirement", "not met (PM 45 deg is out of reach at the horizontal break point: "
                     + ("smallest shortfall kept)" if res.options.require_pm else "GM enforced, PM reported)"), ""))
    w = max(len(r[0]) for r in rows)
    print(res.objective_statement())
    for name, value, unit in rows:
        print(f"{name:<{w}}  {value}  {unit}".rstrip())


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.tuning.tune import tune

    vehicle = vehicle_from_args(args)
    options = tune_options_from_args(args)
    if delay_samples(args) and not options.robust:
        raise NniquadError("--delay-samples delays the robust objective's scenarios: it needs --model full without "
                           "--nominal")
    warm = warm_starts_from_args(args)
    progress = Progress("tune")
    res = tune(vehicle, options, progress=progress.message, warm_starts=warm)
    progress.close()
    print_tune_result(res)
    write_json_if_asked(args, res.to_json())
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_tuning_options(parser)
    add_controller_option(parser, law_names(), "nni",
                          "horizontal law to tune (the laws outside the NI structure are tuned on the same inner loops "
                          "and scenarios, have no sector bound and no certificate of their own)")
    group = parser.add_argument_group("tracking objective (default: the settling time)")
    add_reference_options(group, single_run=False)
    group.add_argument("--tracking-window", type=float, nargs=2, default=None, metavar=("T0", "T1"),
                       help="with --reference: the window of the tracking RMS in s, the tracking run lasting T1 "
                            "(default the second period of a periodic reference, else the whole reference)")
    add_json_option(parser, "tuned gains, metrics, per-seed optima, search statistics and the objective stated")


def _settled_where(res) -> str:
    """Where the robust scenarios' settling is measured: the setpoint for a law whose static stiffness is infinite
    (integral action), else each scenario's wind equilibrium, which is not the setpoint (the tuner's goalpost)."""
    stiffness = min(res.gains.law.static_stiffness(res.gains, res.vehicle.m))
    return "to the setpoint" if math.isinf(stiffness) else "about each scenario's wind equilibrium, not the setpoint"
