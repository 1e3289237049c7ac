"""``nniquad certify``: tune (or take given gains), solve every LMI, write a signed certificate."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from nniquad.cli.commands.common import (
    add_controller_option,
    add_gain_options,
    add_output_option,
    delay_samples,
    apply_integral,
    finite_positive,
    gain_option,
    gains_from_args,
    step_hints,
    vehicle_from_args,
)
from nniquad.cli.commands.tune_command import add_tuning_options, print_tune_result, tune_options_from_args
from nniquad.config import CONTROL_RATE_HZ, DT_S, ROBUST_DELAY_SAMPLES, XI0_M
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS
from nniquad.errors import CertificateError, NniquadError
from nniquad.format import fmt, margin_text, margin_verdict
from nniquad.laws.base import field_unit
from nniquad.laws.classes import within_sector_bound
from nniquad.laws.registry import law_named, law_names, ni_law_names
from nniquad.progress import Progress

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run", "certified_law_names"]

HELP = "tune, then write a certified gain set (JSON)"
DESCRIPTION = """Tune (as 'nniquad tune'), then certify the result and write it to --out.

With --kp, --Gamma and --delta the given gains are certified instead of tuned
(the inner loops are then the defaults unless --attitude-wn etc. are given);
with --controller sni2, --kp, --k, --omega and --zeta (the NNI structure with
the second-order SNI controller k/(s^2 + 2 zeta omega s + omega^2)).

The certificate holds the vehicle, the gains, the sector bound (smallest gamma
and gamma_max), the stability margin and poles, the LMI matrices (plant and
controller NI certificates, closed-loop Lyapunov P with its decay rate, the
parameter-dependent P0 + P1/m over the mass interval, the region-of-attraction
ellipsoid under tilt saturation with its multipliers), whether the start state
lies in each certified region (the reduced loop's and the cascade's, each with
its method and reach; start_certified only if in every one), the performance on the reduced and full models
with their simulation settings, the classical margins at --rate, the time-optimal bound, software versions and
a SHA-256 digest.  It states its law class (--law-class) and the theorem that
certifies it: 'paper' (default) refuses gains outside the sector bound (exit
2, one line: the cascade class drops it); 'cascade' is certified by the
sampled-data cascade section alone.  Gains with an infeasible LMI are refused
as well: no file is written.  Check a certificate with 'nniquad verify'."""


def certified_law_names() -> tuple[str, ...]:
    """The laws ``certify`` takes: those of the NI structure and their integral variants (``--integral``)."""
    return ni_law_names() + tuple(n for n in law_names() if law_named(n).integral)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_tuning_options(parser)
    add_controller_option(parser, certified_law_names(), "nni",
                          "law to certify (a law of the NI structure, or its integral variant)")
    g = parser.add_argument_group("certify given gains instead of tuning")
    add_gain_options(g, certified_law_names())
    g.add_argument("--attitude-wn", type=float, default=None, metavar="RAD_S", help="attitude natural frequency")
    g.add_argument("--attitude-zeta", type=float, default=None, metavar="Z", help="attitude damping ratio")
    g.add_argument("--attitude-accel", type=float, default=None, metavar="RAD_S2",
                   help="deceleration of the attitude error shaping in rad/s^2")
    g.add_argument("--gains-from", metavar="FILE", default=None,
                   help="certify the gains and inner loops of a 'tune --json' file or a certificate (a filtered PD "
                        "is certified as its NNI image: kp' = k_p + k_d/tau_f, Gamma = m k_d/tau_f^2, "
                        "delta = tau_f/(m k_d)); the record of the tune that found them is kept as the "
                        "certificate's tuning record when it was tuned on the same --model (re-certifying a "
                        "certificate with a newer version keeps its design and its record)")
    b = parser.add_argument_group("parameter box of the sampled-data cascade section")
    b.add_argument("--box-scale", type=float, default=None, metavar="S",
                   help="certify the Monte Carlo default ranges scaled by S about nominal in log space "
                        "([lo^S, hi^S]; default: the ranges themselves if they certify, else S halved until it certifies)")
    b.add_argument("--widest-box", action="store_true",
                   help="search the widest scale of the Monte Carlo ranges that certifies (about a minute more) "
                        "and certify it")

    add_output_option(parser, "--out", required=True, metavar="FILE", help="certificate file to write (JSON)")


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.jobs.certify import certify, certify_steps
    from nniquad.tuning.tune import tune

    out = Path(args.out)  # checked by main before this runs (nniquad.io.check_output_path)
    from nniquad.sim.options import check_rate_hz

    # before any tuning: a bad rate fails at once
    rate = check_rate_hz(CONTROL_RATE_HZ if args.rate is None else args.rate, DT_S, error=CertificateError)
    delay = ROBUST_DELAY_SAMPLES if delay_samples(args) is None else delay_samples(args)
    apply_integral(args)
    law = law_named(args.controller)
    gains_given = any(getattr(args, n, None) is not None for n in law.gain_names)
    if args.warm_start and (gains_given or args.gains_from is not None):
        raise NniquadError("--warm-start seeds the tuning: it cannot be given with the gains "
                           f"({', '.join(gain_option(n) for n in law.gain_names)}) or --gains-from")
    box = None
    if args.box_scale is not None:
        from nniquad.analysis.cascade.box_certificate import ParameterBox

        if args.widest_box:
            raise NniquadError("give --box-scale or --widest-box, not both")
        box = ParameterBox.monte_carlo_default().scaled(finite_positive("--box-scale", args.box_scale))
    vehicle = vehicle_from_args(args)
    options = tune_options_from_args(args)
    progress = Progress("certify")
    if args.gains_from is not None and (gains_given or any(getattr(args, n) is not None for n in (
            "attitude_wn", "attitude_zeta", "attitude_accel"))):
        raise NniquadError("give --gains-from or the gains (and the attitude options), not both")
    given = gains_from_args(args, law)
    if args.gains_from is not None:
        from nniquad.cli.commands.tune_command import designs_from_files

        records: list = []
        (gains, inner), = designs_from_files([args.gains_from], "--gains-from", records)
        if law.integral and not gains.law.integral:  # a base design: its integral variant with the seed's ki
            seeded = law.seed_from(gains, vehicle.m)
            if seeded is None:
                raise NniquadError(f"--gains-from holds a {gains.law.name} design: the {law.name} law has no seed "
                                   "from it")
            gains = seeded
        cert = certify(vehicle, gains, inner=inner, options=options, progress=progress.steps(certify_steps(False)),
                       rate_hz=rate, delay_samples=delay,
                       box=box, widest_box=args.widest_box, tuning_record=records[0])
    elif given is not None:
        gains = given
        changes = {k: v for k, v in (("attitude_wn_rad_s", args.attitude_wn), ("attitude_zeta", args.attitude_zeta),
                                     ("attitude_accel_limit_rad_s2", args.attitude_accel)) if v is not None}
        inner = replace(DEFAULT_INNER_LOOP_GAINS, **changes)
        from nniquad.certificates.certificate import reference_run_options
        from nniquad.sim import SimParams
        from nniquad.sim.step_check import check_step

        # the runner's step check on the certificate's full-model reference run, before any LMI is solved
        run = reference_run_options("full", inner, tilt_limit_deg=options.tilt_limit_deg, xi0=XI0_M)
        check_step(SimParams.from_options(vehicle, gains, run), "full",
                   hint=step_hints(attitude="--attitude-wn", motor_lag="the vehicle's tau_motor"))
        cert = certify(vehicle, gains, inner=inner, options=options, progress=progress.steps(certify_steps(False)),
                       rate_hz=rate, delay_samples=delay,
                       box=box, widest_box=args.widest_box)
    else:
        from nniquad.cli.commands.tune_command import warm_starts_from_args

        tuned = tune(vehicle, options, progress=progress.message, warm_starts=warm_starts_from_args(args))
        print_tune_result(tuned)
        cert = certify(vehicle, tuned, options=options, progress=progress.steps(certify_steps(True), done=1),
                       rate_hz=rate, delay_samples=delay,
                       box=box, widest_box=args.widest_box)
    progress(1.0, "certificate signed and verified")
    progress.close()
    path = cert.write(out)
    print(f"certificate: {path}")
    for line in summary_lines(cert):
        print(f"  {line}")
    return 0


def summary_lines(cert: Any) -> list[str]:
    """What ``certify`` prints about a certificate (one line each): the gains, class, reference runs, margins, the
    start per certified region and its top-level verdict, the cascade section, the digest.

    No line claims more than another states: the start is given per method (model, method, reach), the verdict
    names the methods it covers, and a cascade region that fell back to the linear zone says why.

    Parameters
    ----------
    cert
        A :class:`nniquad.certificates.Certificate`.
    """
    from dataclasses import fields

    # lazily, as in run: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.start import lure_fallback_reason, start_lines

    gains, perf = cert.gains, cert.performance
    listed = ", ".join(f"{f.name} = {fmt(getattr(gains, f.name), digits=6)} {field_unit(f)[0]}".rstrip(" -")
                       for f in fields(gains) if getattr(gains, f.name) is not None)
    if "gamma" in cert.sector:
        gamma, gamma_max = cert.sector["gamma"], cert.sector["gamma_max"]
        lines = [f"{cert.controller} gains {listed}; gamma = {fmt(gamma)} "
                 f"{'<=' if within_sector_bound(gamma, gamma_max) else '>'} {gamma_max:g}"]
    else:  # integral action: no sector constant (certificates.integral)
        lines = [f"{cert.controller} gains {listed}; no sector bound (integral action)"]
    if cert.law_class is not None:
        lines.append(f"law class {cert.law_class['name']}: certified by {cert.law_class['theorem']}")
        action = cert.law_class.get("integral_action")
        if action is not None:
            lines += [f"not certified by: {action['not_certified_by']}", f"anti-windup: {action['anti_windup']}"]
    for model in ("reduced", "full"):
        lines.append(f"{model:<7} settling {fmt(perf[model]['settling_s'], 's')} "
                     f"({fmt(cert.ratio_to_bound[model], digits=3)} x bound {fmt(cert.bound['enter_band_s'], 's')}), "
                     f"peak tilt {fmt(perf[model]['peak_tilt_deg'], 'deg')}")
    if cert.margins is not None:
        req = cert.margins["required"]
        for name, p in cert.margins["break_points"].items():
            lines.append(f"{name} margins at {cert.margins['rate_hz']:g} Hz: "
                         f"{margin_text(p['gm_db'], p['gm_lower_db'], p['pm_deg'])}: "
                         f"{margin_verdict(p, req['gm_db'], req['pm_deg'])}")
    lines += start_lines(cert, lambda v: fmt(v, "m"))
    if cert.cascade is not None:
        cas = cert.cascade
        bx = cas["box"]
        lines.append(f"sampled-data cascade at {cas['rate_hz']:g} Hz certified over mass x{bx['mass_factor'][0]:.3g}-"
                     f"{bx['mass_factor'][1]:.3g}, inertia x{bx['inertia_factor'][0]:.3g}-{bx['inertia_factor'][1]:.3g}, "
                     f"attitude gain x{bx['attitude_gain_factor'][0]:.3g}-{bx['attitude_gain_factor'][1]:.3g}, "
                     f"motor tau x{bx['tau_motor_factor'][0]:.3g}-{bx['tau_motor_factor'][1]:.3g} "
                     f"(covers the Monte Carlo ranges: {fmt(cas['covers_monte_carlo_default'])}); decay "
                     f"{fmt(cas['decay_rate_1_s'], '1/s')}, grid {cas['grid']['size']} points worst rho "
                     f"{cas['grid']['worst_rho']:.6f}")
        proof = cas.get("box_proof")
        if proof:
            T = 1.0 / float(cas["rate_hz"])
            lines.append(f"box between the grid points: {proof['outcome']} on {proof['cells']} cells "
                         f"({proof['initial_cells']} + {proof['refined']} cut) at rho {proof['rho']:.6f} "
                         f"(decay {fmt(-math.log(proof['rho']) / T, '1/s')}); corner proofs by verified Cholesky, the "
                         f"interpolation allowance between corners estimated")
        why = lure_fallback_reason(cert)
        if why is not None:
            lines.append(f"cascade region: the linear zone, not the Lur'e region: {why}")
        search = cas.get("box_search")
        if search:
            failed = search["first_failed_scale"]
            lines.append(f"box search ({search['method']}): widest scale certified "
                         f"{search['widest_certified_scale']:.4g} x the Monte Carlo ranges (log space), first failed "
                         f"{failed if isinstance(failed, str) else format(failed, '.4g')}")
    if cert.delay_samples is not None:
        lines.append(f"measurement delay certified: {cert.delay_samples} samples "
                     f"({1000.0 * cert.delay_samples / float(cert.cascade['rate_hz']):g} ms at "
                     f"{cert.cascade['rate_hz']:g} Hz)")
    lines.append(f"digest sha256 {cert.signature}")
    return lines
