"""``nniquad simulate``: one closed-loop run on the linear, reduced or full model."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from nniquad.cli.commands.common import (
    add_controller_option,
    add_delay_option,
    add_gain_options,
    add_json_option,
    add_output_option,
    add_tilt_limit_option,
    add_vehicle_option,
    add_xi0_option,
    delay_samples,
    gain_option,
    law_gains,
    step_hints,
    vehicle_from_args,
)
from nniquad.cli.commands.reference_options import add_reference_options, reference_settings, tracking_window
from nniquad.config import (
    ALTITUDE_LIMIT_M,
    CONTROL_RATE_HZ,
    DIVERGENCE_FACTOR,
    DT_S,
    NOISE_BUDGET_ROTOR_LIMIT_SHARE,
    NOISE_BUDGET_SIGMA_M,
    NOISE_BUDGET_TILT_RMS_DEG,
    OUTPUT_DT_S,
    STEADY_OFFSET_WINDOW_S,
    XI0_M,
)
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS
from nniquad.errors import EXIT_CHECK_FAILED, CertificateError, GainError, NniquadError, SimulationError
from nniquad.format import fmt
from nniquad.io import atomic_write_json, check_output_paths, output_transaction
from nniquad.laws.base import gains_text
from nniquad.laws.registry import LAWS, law_named, law_names
from nniquad.progress import Progress
from nniquad.resources import check_estimate, simulation_estimate
from nniquad.sim.options import CONTROLLER_SAMPLING

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run", "PLAIN_HORIZON_S"]

HELP = "simulate the closed loop on the linear, reduced or full model"
DESCRIPTION = f"""Simulate the paper's closed loop from xi_h(0) = ({XI0_M[0]:g}, {XI0_M[1]:g}) m at rest.

Models:
  linear   the reduced horizontal loop of the paper, both axes, no limits
  reduced  the same with the horizontal command limited by the tilt limit
           (|a_h| <= g tan(limit)), attitude assumed instant
  full     the 12-state vehicle (exact Euler-Lagrange model, rotor gyroscopic
           terms, rotor-speed saturation) with altitude hold, yaw hold, an
           attitude loop (gyro rates) tracking the tilt the horizontal loop
           commands, and the tilt limit.  No horizontal velocity is used (but by the
           pd_velocity law, the yardstick with a perfect velocity sensor).

The horizontal command is the law's (--controller, default nni, the paper's:
-kp xi + z/m, z the output of the NNI controller z' = -Gamma delta z + Gamma xi,
in positive feedback).  With --rate HZ (or --noise) the position is sampled at
HZ and the law runs in discrete time at that rate, the exact zero-order hold
of its realisation (NNI: z[k+1] = exp(-Gamma delta T) z[k] + (1 - exp(-Gamma
delta T))/delta xi[k], a[k] = -kp xi[k] + z[k]/m, T = 1/HZ), a[k] held over the
period; the attitude loop, motors and altitude loop stay continuous.  Defaults
are the paper's gains (kp = 5, Gamma = 160, delta = 0.6) and initial state;
another law's gains are all given (--kp, --k, --omega, ...) or come from
--certificate.

With --certificate CERT the run is the certificate's reference run
performance.full (performance.reduced with --model reduced): its vehicle,
gains, inner loops, rate and sampling, motor lag, start, horizon, tilt limit
and output period.  Then the stated numbers are compared with the re-simulated
ones within the certificate's tolerances; a run that does not reproduce them
exits 1.  An option given with --certificate overrides that setting: the
options that change the run are named, and nothing is compared (the run is
not the certificate's).

Prints settling time (2 % band around the setpoint, last exit), overshoot, peak tilt, whether
the vehicle was lost ("diverged": it blew up -- a non-finite state or a distance
beyond {DIVERGENCE_FACTOR:g} x its start -- or lost its altitude by more than {ALTITUDE_LIMIT_M:g} m), whether it lost
its altitude, and the verdict, which names the cause ("diverged" for a blow-up,
"altitude lost", "not settled").  With --reference the law follows a reference
(settling and overshoot then do not apply: the verdict is "followed" unless the
vehicle is lost; the run starts on the reference with its velocity unless
--start-at-rest, and with --certificate it is no longer the certificate's run) and
the tracking error is printed: RMS and maximum over --tracking-window, the
arrival at each waypoint (2 % band of its leg), and the tilt the reference
demands against the limit (docs/follow.md).  The steady offset is the mean
distance from the setpoint over the last {STEADY_OFFSET_WINDOW_S:g} s (a constant --wind leaves one
unless the law integrates).  The noise budget: the RMS of the commanded tilt
over the hover window (the whole run from --xi0 0 0, else from the settling
time on) and the share of samples with a rotor command at 0 or its maximum; a
hover run (--xi0 0 0) settles in the band of the nominal start; a
noisy run is judged against {NOISE_BUDGET_TILT_RMS_DEG:g} deg and {100 * NOISE_BUDGET_ROTOR_LIMIT_SHARE:g} % (the hover check:
--xi0 0 0 --noise {NOISE_BUDGET_SIGMA_M:g} --output-dt {DT_S:g}).  --json writes them with the trajectory file
(.npz next to the JSON, or --trajectory FILE with .npz or .csv).  Runs that take
more than a few seconds show progress on stderr."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--model", choices=("linear", "reduced", "full"), default="full",
                        help="model to simulate (default full)")
    g = parser.add_argument_group("law and gains (default: the paper's law and gains)")
    add_controller_option(g, law_names(), "nni", "horizontal law to simulate")
    add_gain_options(g)
    g.add_argument("--certificate", metavar="FILE", default=None,
                   help="fly a certificate's reference run (its vehicle, gains, inner loops, rate, motor lag, start "
                        "and horizon; form and digest checked) and compare it with what the certificate states")
    add_vehicle_option(parser)
    s = parser.add_argument_group("run (with --certificate every default is the certificate's reference run)")
    add_xi0_option(s)
    add_tilt_limit_option(s)
    parser.set_defaults(xi0=None, tilt_limit=None)  # given or not: an option given with --certificate overrides it
    s.add_argument("--horizon", type=float, default=None, metavar="T", help="simulated time in s (default 60)")
    s.add_argument("--dt", type=float, default=None, metavar="S", help=f"RK4 step in s (default {DT_S:g})")
    s.add_argument("--output-dt", type=float, default=None, metavar="S",
                   help=f"output sample period in s, a multiple of --dt (default {OUTPUT_DT_S:g})")
    d = parser.add_argument_group("disturbances and uncertainty")
    d.add_argument("--noise", type=float, default=None, metavar="SIGMA",
                   help="position-noise standard deviation in m (default 0); the measurement is sampled and held")
    d.add_argument("--rate", type=float, default=None, metavar="HZ",
                   help=f"control rate: the position is sampled at HZ and the law runs in discrete time "
                        f"at HZ (exact ZOH, as 'nniquad export' writes it); default {CONTROL_RATE_HZ:g} with --noise, "
                        "else continuous measurement and controller (the paper's model)")
    d.add_argument("--sampling", choices=CONTROLLER_SAMPLING, default=None,
                   help="how the controller sees the position: continuous; held (sampled and held, controller "
                        "integrated continuously on it); discrete (default with --rate or --noise)")
    add_delay_option(d, None, "samples the measurement (discrete at --rate, default "
                              f"{CONTROL_RATE_HZ:g} Hz); default 0.  With --certificate, a delay beyond the one the "
                              "certificate certifies is flagged")
    d.add_argument("--seed", type=int, default=None, metavar="N", help="seed of the noise and gust (default 0)")
    d.add_argument("--wind", type=float, nargs=2, default=None, metavar=("FX", "FY"),
                   help="constant wind force north/east in N (default 0 0)")
    d.add_argument("--gust", type=float, default=None, metavar="SIGMA_N",
                   help="gust force standard deviation per axis in N (first-order Gauss-Markov; default 0)")
    d.add_argument("--gust-tau", type=float, default=None, metavar="S", help="gust correlation time in s (default 1)")
    d.add_argument("--motor-lag", action=argparse.BooleanOptionalAction, default=None,
                   help="first-order rotor-speed lag (full model; default off, or the certificate's)")
    d.add_argument("--tau-motor", type=float, default=None, metavar="S",
                   help="motor time constant in s (default: the vehicle's)")
    d.add_argument("--true-mass", type=float, default=None, metavar="KG",
                   help="plant mass in kg (the controller keeps the vehicle's nominal mass)")
    d.add_argument("--attitude-wn", type=float, default=None, metavar="RAD_S",
                   help="attitude-loop natural frequency in rad/s (full model; default 25, or the certificate's)")
    d.add_argument("--attitude-zeta", type=float, default=None, metavar="Z",
                   help="attitude-loop damping ratio (full model; default 0.8, or the certificate's)")
    add_reference_options(parser.add_argument_group("reference (default: hold the origin)"))
    add_json_option(parser, "metrics, gains, options and the trajectory file path")
    add_output_option(parser, "--trajectory", metavar="FILE", default=None,
                        help="write the trajectory here (.npz or .csv); default with --json: JSON name + .traj.npz")
    add_output_option(parser, "--plot", metavar="FILE.png", default=None, help="plot the run to a PNG file")


#: The options that set a field of the run (dest, SimOptions field); with --certificate, one given overrides it.
_RUN_FIELDS = (("model", "model"), ("horizon", "horizon_s"), ("dt", "dt_s"), ("output_dt", "output_dt_s"),
               ("xi0", "xi0"), ("tilt_limit", "tilt_limit_deg"), ("noise", "noise_sigma_m"), ("seed", "seed"),
               ("wind", "wind_N"), ("gust", "gust_N"), ("gust_tau", "gust_tau_s"), ("motor_lag", "motor_lag"),
               ("tau_motor", "tau_motor_s"), ("true_mass", "true_mass_kg"), ("delay_samples", "delay_samples"))
#: The option that sets each run field (for the list of overrides).
_OPTION_OF = {**{f: "--" + d.replace("_", "-") for d, f in _RUN_FIELDS}, "noise_rate_hz": "--rate",
              "sampling": "--sampling", "inner": "--attitude-wn/--attitude-zeta", "vehicle": "--vehicle",
              "reference": "--reference", "v0": "--reference", "feedforward": "--feedforward",
              "feedforward_lead_s": "--feedforward-lead"}
#: Plain runs (no certificate): the simulated time [s].
PLAIN_HORIZON_S = 60.0


def _plain_options(model: str, inner):
    """The options of a run that is not a certificate's: the defaults, continuous measurement and law."""
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.sim import SimOptions

    return SimOptions(model=model, horizon_s=PLAIN_HORIZON_S, noise_rate_hz=CONTROL_RATE_HZ,
                      controller_sampling="continuous", inner=inner)


def _certificate_run(args: argparse.Namespace):
    """The certificate's reference run of ``--model`` (``full`` for ``linear``), or ``None`` and a one-line note
    when the document is not a complete certificate (its gains, inner loops and vehicle then fly alone)."""
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.certificate import Certificate, load_certificate
    from nniquad.certificates.reference_run import ReferenceRun
    from nniquad.certificates.sections import certificate_gains, certificate_inner_loop, certificate_vehicle

    explicit = [n for law_ in LAWS.values() for n in law_.gain_names if getattr(args, n, None) is not None]
    if explicit:
        raise GainError(f"give either --certificate or {gain_option(explicit[0])}, not both")
    data = load_certificate(args.certificate)  # form and digest (a mismatch is a failed check, exit 1)
    gains = certificate_gains(data)
    try:
        return Certificate.from_json(data, where=args.certificate).run_settings(
            "full" if args.model == "linear" else args.model), None
    except CertificateError as exc:
        vehicle = certificate_vehicle(data) if "vehicle" in data else vehicle_from_args(args)
        options = _plain_options(args.model, certificate_inner_loop(data))
        note = (f"{args.certificate} states no reference run that can be flown again ({exc}): its gains fly with "
                "this command's options, and nothing is compared")
        return ReferenceRun(vehicle, gains, options), note


def _sampling(args: argparse.Namespace, base, dt: float) -> tuple[float, str]:
    """The rate and the controller sampling of the run (see --rate and --sampling), from the base run's."""
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.sim.options import check_rate_hz

    sampling = args.sampling
    if sampling is None:
        sampled = args.rate is not None or (args.noise or 0.0) > 0 or (delay_samples(args) or 0) > 0
        sampling = "discrete" if sampled and base.sampling == "continuous" else base.sampling
    if args.rate is not None and sampling == "continuous":
        raise SimulationError("--rate samples the measurement: it cannot be used with --sampling continuous")
    rate = base.noise_rate_hz if args.rate is None else args.rate
    # the step is validated again by SimOptions; a bad --dt is named there
    dt = dt if isinstance(dt, (int, float)) and dt > 0 else DT_S
    return check_rate_hz(rate, dt, discrete=sampling == "discrete"), sampling


def _the_run(args: argparse.Namespace):
    """The run to fly: the certificate's reference run (or a plain run) with the options given applied.

    Returns the run, the base run it was made from (``None`` for a plain run), the options that changed the
    base run, and a note (``None``, or why a certificate has no reference run).
    """
    from dataclasses import replace

    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.reference_run import ReferenceRun

    note = None
    if args.certificate:
        base, note = _certificate_run(args)
    else:
        base = ReferenceRun(vehicle_from_args(args), law_gains(args, law_named(args.controller)),
                            _plain_options(args.model, DEFAULT_INNER_LOOP_GAINS))
    changes = {}
    for dest, name in _RUN_FIELDS:
        value = getattr(args, dest, None)
        if value is not None:
            changes[name] = tuple(value) if isinstance(value, list) else value
    changes.update(reference_settings(args))
    inner = {k: v for k, v in (("attitude_wn_rad_s", args.attitude_wn), ("attitude_zeta", args.attitude_zeta))
             if v is not None}
    rate, sampling = _sampling(args, base.options, changes.get("dt_s", base.options.dt_s))
    if sampling != base.options.sampling:
        changes["controller_sampling"] = sampling
    run = base.with_(vehicle=vehicle_from_args(args) if args.vehicle else None, noise_rate_hz=rate,
                     inner=replace(base.options.inner, **inner), **changes)
    if base.stated is None:  # a plain run, or a document without a reference run: nothing to override
        return run, None, [], note
    was, now = base.options, run.options
    changed = [f for f in now.to_json() if f not in ("controller_sampling", "sample_hold", "noise_rate_hz")
               and getattr(now, f) != getattr(was, f)]
    if now.sampling != was.sampling:
        changed.append("sampling" if args.sampling else "noise_rate_hz")  # --rate or --noise sampled it
    if now.sampled and now.noise_rate_hz != was.noise_rate_hz and "noise_rate_hz" not in changed:
        changed.append("noise_rate_hz")
    if run.vehicle.as_dict() != base.vehicle.as_dict():
        changed.insert(0, "vehicle")
    if not changed:
        return base, base, [], note
    option_of = {**_OPTION_OF, **({"xi0": "--reference"} if args.reference and not args.start_at_rest else {})}
    return run, base, list(dict.fromkeys(option_of.get(f, f) for f in changed)), note


def run(args: argparse.Namespace) -> int:
    flight, base, overridden, note = _the_run(args)
    vehicle, gains, options = flight.vehicle, flight.gains, flight.options
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.sim import SimParams, simulate
    from nniquad.sim.step_check import check_step

    traj_path = args.trajectory
    if traj_path is None and args.json:
        j = Path(args.json)
        traj_path = str(j.with_name(j.stem + ".traj.npz"))
        check_output_paths([("--json", args.json), ("--json's trajectory file", traj_path), ("--plot", args.plot)])
    if traj_path is not None and Path(traj_path).suffix.lower() not in (".npz", ".csv"):
        raise NniquadError(f"--trajectory must end in .npz or .csv, got {traj_path}")
    # the runner's step check, before the estimate, naming this command's options
    check_step(SimParams.from_options(vehicle, gains, options), options.model,
               hint=step_hints(attitude="--attitude-wn or --dt", yaw="--dt", altitude="--dt",
                               motor_lag="--tau-motor or --dt"))
    check_estimate(simulation_estimate(options.model, options.horizon_s, options.dt_s, options.output_dt_s),
                   option=f"--horizon {options.horizon_s:g}", error=SimulationError)

    progress = Progress("simulate")
    progress.note(f"{options.model} model, {options.horizon_s:g} s simulated")
    traj = simulate(**flight.kwargs(), progress=progress.fraction)[0]  # looked up now: the tests stub it
    progress.close()
    m = traj.metrics()

    print(f"vehicle: {vehicle.name}")
    print(f"model: {args.model}   gains: {gains_text(gains)}")
    if note is not None:
        print(f"certificate: {note}")
    elif base is not None and overridden:
        print(f"certificate: {args.certificate}, its reference run performance.{base.model} with {', '.join(overridden)} "
              "overridden: not the certificate's run, so nothing is compared")
    elif base is not None:
        print(f"certificate: {args.certificate}, its reference run performance.{base.model} (vehicle, inner loops, "
              f"{_sampling_text(options)}, motor lag {fmt(options.motor_lag)}, start, horizon {options.horizon_s:g} s)")
    delay = _delay_coverage(args, options)
    if delay is not None and not delay.covered:
        print(f"certificate: {delay.note()}")
    rows = [
        ("settling time (2 % band)", fmt(m.settling_s, "s"),
         "(following a reference)" if m.follows_reference else "not settled" if m.settling_s is None else ""),
        ("overshoot along xi0", fmt(m.overshoot_pct, "%"), ""),
        ("peak tilt", fmt(m.peak_tilt_deg, "deg"), ""),
        ("peak commanded tilt", fmt(m.peak_cmd_tilt_deg, "deg"), ""),
        ("time on the tilt limit", fmt(None if m.tilt_limit_fraction is None else 100 * m.tilt_limit_fraction, "%"),
         ""),
        ("peak rotor speed", fmt(m.peak_rotor_speed_rad_s, "rad/s"), ""),
        ("peak altitude deviation", fmt(m.altitude_dev_m, "m"), ""),
        ("tilt RMS after settling", fmt(m.tilt_jitter_rms_deg, "deg"), ""),
        (f"steady offset (last {STEADY_OFFSET_WINDOW_S:g} s)", fmt(m.steady_offset_m, "m"), "(from the setpoint)"),
        ("commanded tilt RMS", fmt(m.tilt_command_rms_deg, "deg"),
         "(hover window)" if m.tilt_command_rms_deg is not None else "(no hover window: not settled)"),
        ("rotor command at a limit", fmt(None if m.rotor_limit_share is None else 100 * m.rotor_limit_share, "%"),
         f"(of the samples every {options.output_dt_s:g} s)" if m.rotor_limit_share is not None else ""),
        *_noise_budget_rows(options, m),
        ("diverged", fmt(m.diverged), "(vehicle lost)" if m.diverged else ""),
        ("altitude lost", fmt(m.altitude_lost), "" if m.altitude_lost is None else f"(> {ALTITUDE_LIMIT_M:g} m)"),
        ("verdict", m.failure or ("followed" if m.follows_reference else "settled"), ""),
        ("horizon", fmt(m.horizon_s, "s"), ""),
    ]
    for name, value, comment in rows:
        print(f"{name:<26} {value:>16}  {comment}")
    tracking = traj.tracking(tracking_window(args))
    if tracking is not None:
        print(f"reference: {options.reference.describe()}, feedforward {'on' if options.feedforward else 'off'}")
        print("\n".join(tracking.lines()))
    compared = _compare(flight, m) if base is not None and not overridden and note is None else None

    # every output or none: a failed plot must not leave the trajectory file behind
    with output_transaction():
        written = None if traj_path is None else traj.save(traj_path)
        if args.plot:
            from nniquad.sim.plots import trajectory_plot

            trajectory_plot(traj, args.plot)
        data = {
            "model": args.model,
            "settling_s": m.settling_s,
            "overshoot_pct": m.overshoot_pct,
            "peak_tilt_deg": m.peak_tilt_deg,
            "diverged": m.diverged,
            "altitude_lost": m.altitude_lost,
            "failure": m.failure,
            "horizon_s": m.horizon_s,
            "steady_offset_m": m.steady_offset_m,
            "tilt_command_rms_deg": m.tilt_command_rms_deg,
            "rotor_limit_share": m.rotor_limit_share,
            "trajectory": None if written is None else str(written),
            "metrics": {**m.to_json(), **({} if tracking is None else tracking.to_json())},
            "gains": gains.as_dict(),
            "vehicle": vehicle.as_dict(),
            "options": options.to_json(),
        }
        if args.certificate:
            data["certificate"] = {"path": args.certificate, "note": note, "overridden": overridden,
                                   "run": None if base is None else f"performance.{base.model}",
                                   "stated": None if compared is None else dict(flight.stated),
                                   "reproduced": None if compared is None else not compared,
                                   "beyond_certified_delay": delay.beyond, "delay_covered": delay.covered}
        if args.json:
            atomic_write_json(args.json, data)
    for path in (written, args.plot, args.json):
        if path is not None:
            print(f"wrote {path}", file=sys.stderr)
    return EXIT_CHECK_FAILED if compared else 0


def _noise_budget_rows(options, m) -> list[tuple[str, str, str]]:
    """The noise-budget verdict of a noisy run: commanded tilt RMS and rotor-limit share against the budget."""
    if not options.noise_sigma_m > 0 or m.tilt_command_rms_deg is None or m.rotor_limit_share is None:
        return []
    within = (m.tilt_command_rms_deg <= NOISE_BUDGET_TILT_RMS_DEG
              and m.rotor_limit_share <= NOISE_BUDGET_ROTOR_LIMIT_SHARE)
    step = ("" if options.output_dt_s == options.dt_s
            else f"; the rotor share counts output samples: --output-dt {options.dt_s:g} counts every step")
    return [("noise budget", "within" if within else "over",
             f"(<= {NOISE_BUDGET_TILT_RMS_DEG:g} deg, <= {100 * NOISE_BUDGET_ROTOR_LIMIT_SHARE:g} % at "
             f"{100 * NOISE_BUDGET_SIGMA_M:g} cm{step})")]


def _sampling_text(options) -> str:
    """How the run measures the position: ``discrete at 100 Hz`` or ``continuous``."""
    return f"{options.sampling} at {options.rate_hz:g} Hz" if options.sampled else options.sampling


def _compare(flight, m) -> list[str]:
    """Print the certificate's stated numbers of the run beside the re-simulated ones; the ones that differ."""
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.certificate import TOLERANCES
    from nniquad.certificates.reference_run import METRIC_TOLERANCES, run_metrics

    got = run_metrics(m)
    bad = flight.differences(got, TOLERANCES)
    what = f"performance.{flight.model}"
    print(f"{what + ' (stated)':<28} " + ", ".join(f"{k} {_full(flight.stated.get(k))}" for k in got))
    print(f"{'re-simulated':<28} " + ", ".join(f"{k} {_full(got[k])}" for k in got))
    within = ", ".join(f"{k} {TOLERANCES[t]:g}" for k, t in METRIC_TOLERANCES.items())
    print(f"reproduces {what}: " + (f"yes (within {within})" if not bad else
                                   f"NO: {', '.join(bad)} differ beyond {within}"))
    return bad


def _full(value) -> str:
    """A stated number to every digit the certificate states (``repr``), ``None`` as ``-``."""
    return "-" if value is None else fmt(value) if isinstance(value, bool) else repr(value)


def _delay_coverage(args: argparse.Namespace, options):
    """With ``--certificate``: whether it covers this run's measurement delay (a ``DelayCoverage``), else ``None``."""
    if not args.certificate:
        return None
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.certificate import load_certificate
    from nniquad.scenarios.ranges import DelayCoverage, certified_delay_samples

    return DelayCoverage(options.delay_samples, certified_delay_samples(load_certificate(args.certificate)))
