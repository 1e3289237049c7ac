"""``nniquad simulate``: one closed-loop run on the linear, reduced or full model."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from nniquad.cli.commands.common import (
    add_controller_option,
    add_gain_options,
    add_json_option,
    add_output_option,
    add_tilt_limit_option,
    add_vehicle_option,
    add_xi0_option,
    gain_option,
    law_gains,
    step_hints,
    vehicle_from_args,
)
from nniquad.cli.commands.reference_options import add_reference_options, reference_settings, tracking_window
from nniquad.config import ALTITUDE_LIMIT_M, CONTROL_RATE_HZ, DIVERGENCE_FACTOR, XI0_M
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS
from nniquad.errors import GainError, NniquadError, SimulationError
from nniquad.format import fmt
from nniquad.io import atomic_write_json, check_output_paths, output_transaction
from nniquad.laws.base import gains_text
from nniquad.laws.registry import LAWS, law_named, law_names
from nniquad.progress import Progress
from nniquad.resources import check_estimate, simulation_estimate
from nniquad.sim.options import CONTROLLER_SAMPLING

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run", "gains_from_certificate"]

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

Prints settling time (2 % band, last exit), overshoot, peak tilt, whether
the vehicle was lost ("diverged": it blew up -- a non-finite state or a distance
beyond {DIVERGENCE_FACTOR:g} x its start -- or lost its altitude by more than {ALTITUDE_LIMIT_M:g} m), whether it lost
its altitude, and the verdict, which names the cause ("diverged" for a blow-up,
"altitude lost", "not settled").  With --reference the law follows a reference
(the settling numbers then still measure the distance to the origin) and the
tracking error is printed too: RMS and maximum over --tracking-window, the
arrival at each waypoint (2 % band of its leg), and the tilt the reference
demands against the limit (docs/follow.md).  --json writes them with the trajectory file
(.npz next to the JSON, or --trajectory FILE with .npz or .csv).  Runs that take
more than a few seconds show progress on stderr."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--model", choices=("linear", "reduced", "full"), default="full",
                        help="model to simulate (default full)")
    g = parser.add_argument_group("law and gains (default: the paper's law and gains)")
    add_controller_option(g, law_names(), "nni", "horizontal law to simulate")
    add_gain_options(g)
    g.add_argument("--certificate", metavar="FILE", default=None,
                   help="take the gains and inner loops from a certificate (form and digest checked; "
                        "'nniquad verify' checks the rest)")
    add_vehicle_option(parser)
    s = parser.add_argument_group("run")
    add_xi0_option(s)
    add_tilt_limit_option(s)
    s.add_argument("--horizon", type=float, default=60.0, metavar="T", help="simulated time in s (default 60)")
    s.add_argument("--dt", type=float, default=1e-3, metavar="S", help="RK4 step in s (default 0.001)")
    s.add_argument("--output-dt", type=float, default=0.01, metavar="S",
                   help="output sample period in s, a multiple of --dt (default 0.01)")
    d = parser.add_argument_group("disturbances and uncertainty")
    d.add_argument("--noise", type=float, default=0.0, metavar="SIGMA",
                   help="position-noise standard deviation in m (default 0); the measurement is sampled and held")
    d.add_argument("--rate", type=float, default=None, metavar="HZ",
                   help=f"control rate: the position is sampled at HZ and the law runs in discrete time "
                        f"at HZ (exact ZOH, as 'nniquad export' writes it); default {CONTROL_RATE_HZ:g} with --noise, "
                        "else continuous measurement and controller (the paper's model)")
    d.add_argument("--sampling", choices=CONTROLLER_SAMPLING, default=None,
                   help="how the controller sees the position: continuous; held (sampled and held, controller "
                        "integrated continuously on it); discrete (default with --rate or --noise)")
    d.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the noise and gust (default 0)")
    d.add_argument("--wind", type=float, nargs=2, default=[0.0, 0.0], metavar=("FX", "FY"),
                   help="constant wind force north/east in N (default 0 0)")
    d.add_argument("--gust", type=float, default=0.0, metavar="SIGMA_N",
                   help="gust force standard deviation per axis in N (first-order Gauss-Markov; default 0)")
    d.add_argument("--gust-tau", type=float, default=1.0, metavar="S", help="gust correlation time in s (default 1)")
    d.add_argument("--motor-lag", action="store_true", help="first-order rotor-speed lag (full model)")
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


def gains_from_certificate(path: str | Path):
    """The gains of a certificate whose form and digest check out (``nniquad verify`` checks the rest).

    Raises
    ------
    CertificateError
        Unreadable file, invalid JSON, wrong schema, digest mismatch, missing or
        malformed ``gains``.
    """
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.certificate import certificate_gains, load_certificate

    return certificate_gains(load_certificate(path))


def _gains(args: argparse.Namespace):
    """The gains: the certificate's, or the law's given on the command line (the paper's law: the paper's gains
    fill what is not given)."""
    law = law_named(args.controller)
    explicit = [n for law_ in LAWS.values() for n in law_.gain_names if getattr(args, n, None) is not None]
    if args.certificate:
        if explicit:
            raise GainError(f"give either --certificate or {gain_option(explicit[0])}, not both")
        return gains_from_certificate(args.certificate)
    return law_gains(args, law)


def _inner(args: argparse.Namespace):
    """Inner-loop gains: the certificate's (its ``inner_loop``) or the defaults, then the explicit options."""
    from dataclasses import replace


    inner = DEFAULT_INNER_LOOP_GAINS
    if args.certificate:
        # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
        from nniquad.certificates.certificate import certificate_inner_loop, load_certificate

        inner = certificate_inner_loop(load_certificate(args.certificate))
    changes = {k: v for k, v in (("attitude_wn_rad_s", args.attitude_wn), ("attitude_zeta", args.attitude_zeta))
               if v is not None}
    return replace(inner, **changes)


def _sampling(args: argparse.Namespace) -> tuple[float, str]:
    """The rate and the controller sampling of the run (see --rate and --sampling)."""
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.sim.options import check_rate_hz

    sampling = args.sampling
    if sampling is None:
        sampling = "discrete" if (args.rate is not None or (args.noise or 0.0) > 0) else "continuous"
    if args.rate is not None and sampling == "continuous":
        raise SimulationError("--rate samples the measurement: it cannot be used with --sampling continuous")
    rate = CONTROL_RATE_HZ if args.rate is None else args.rate
    # the step is validated again by SimOptions; a bad --dt is named there
    dt = args.dt if isinstance(args.dt, (int, float)) and args.dt > 0 else 1e-3
    return check_rate_hz(rate, dt, discrete=sampling == "discrete"), sampling


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.sim import SimOptions, simulate

    vehicle = vehicle_from_args(args)
    gains = _gains(args)
    rate, sampling = _sampling(args)
    options = SimOptions(
        model=args.model,
        horizon_s=args.horizon,
        dt_s=args.dt,
        output_dt_s=args.output_dt,
        tilt_limit_deg=args.tilt_limit,
        xi0=tuple(args.xi0),
        noise_sigma_m=args.noise,
        noise_rate_hz=rate,
        controller_sampling=sampling,
        seed=args.seed,
        wind_N=tuple(args.wind),
        gust_N=args.gust,
        gust_tau_s=args.gust_tau,
        motor_lag=args.motor_lag,
        tau_motor_s=args.tau_motor,
        true_mass_kg=args.true_mass,
        inner=_inner(args),
    )
    options = options.with_(**reference_settings(args))
    from nniquad.sim import SimParams
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
    progress.note(f"{args.model} model, {options.horizon_s:g} s simulated")
    traj = simulate(vehicle, gains, options, progress=progress.fraction)[0]
    progress.close()
    m = traj.metrics()

    print(f"vehicle: {vehicle.name}")
    print(f"model: {args.model}   gains: {gains_text(gains)}")
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
        ("diverged", fmt(m.diverged), "(vehicle lost)" if m.diverged else ""),
        ("altitude lost", fmt(m.altitude_lost), "" if m.altitude_lost is None else f"(> {ALTITUDE_LIMIT_M:g} m)"),
        ("verdict", m.failure or ("followed" if m.follows_reference else "settled"), ""),
        ("horizon", fmt(m.horizon_s, "s"), ""),
    ]
    for name, value, note in rows:
        print(f"{name:<26} {value:>16}  {note}")
    tracking = traj.tracking(tracking_window(args))
    if tracking is not None:
        print(f"reference: {options.reference.describe()}, feedforward {'on' if options.feedforward else 'off'}")
        print("\n".join(tracking.lines()))


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
            "trajectory": None if written is None else str(written),
            "metrics": {**m.to_json(), **({} if tracking is None else tracking.to_json())},
            "gains": gains.as_dict(),
            "vehicle": vehicle.as_dict(),
            "options": options.to_json(),
        }
        if args.json:
            atomic_write_json(args.json, data)
    for path in (written, args.plot, args.json):
        if path is not None:
            print(f"wrote {path}", file=sys.stderr)
    return 0
