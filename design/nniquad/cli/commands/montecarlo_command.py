"""``nniquad montecarlo``: robustness statistics of a certificate over perturbed vehicles."""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
import shlex
import sys
from pathlib import Path
from typing import Any

from nniquad.cli.commands.common import add_delay_option, add_output_option, delay_samples
from nniquad.cli.commands.reference_options import add_reference_options, reference_settings
from nniquad.config import CONTROL_RATE_HZ, MC_STALL_TIMEOUT_S, WIND_WEIGHT_FRACTION_RANGE
from nniquad.errors import EXIT_INTERRUPTED, EXIT_TERMINATED, MonteCarloError
from nniquad.io import atomic_write_json, check_output_paths
from nniquad.laws.base import gains_text
from nniquad.progress import Progress
from nniquad.resources import check_estimate, montecarlo_estimate, usable_cpu_count

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run", "partial_path"]

HELP = "Monte Carlo robustness study of a certificate"
DESCRIPTION = f"""Draw N perturbed scenarios of a certificate's gain set and simulate each on
the full vehicle model (default 20 s).  Each scenario perturbs:

  mass                 nominal x U[0.8, 1.2]           (--mass-range)
  inertia              each axis x U[0.8, 1.2]         (--inertia-range)
  attitude-loop gain   x U[0.7, 1.3]                   (--attitude-gain-range)
  motor time constant  nominal x U[0.5, 2], lag on     (--tau-motor-factor-range;
                                                        absolute: --tau-motor-range, in s)
  position noise       sigma U[0, 2] cm at 100 Hz      (--noise-range, in m)
  wind force           U[{100 * WIND_WEIGHT_FRACTION_RANGE[0]:g}, {100 * WIND_WEIGHT_FRACTION_RANGE[1]:g}] % of the weight m g,   (--wind-fraction-range, or
                       random direction                 --wind-range in N)
  initial displacement uniform over the disk of the certificate's certified
                       region (capped at 5 m), at rest (--max-displacement)

A scenario succeeds when it settles (2 % of the certificate's |xi0| around the
setpoint, last exit) and never diverges (non-finite state, distance beyond
100 x its start, altitude deviation beyond 2 m).  A law without integral
action holds a steady wind at a displaced equilibrium: outside the band, that
is not settled.  The settling about the wind equilibrium (the verdict of
earlier versions) is still reported as settling_time_about_wind_equilibrium_s;
it decides nothing.  Each scenario also reports its steady offset (mean
distance from the setpoint over the last second), the commanded-tilt RMS
over its hover window and the share of samples with a rotor command at a
limit; the summary gives their p50, p95 and max.

Prints the success rate with its Wilson 95 % interval, settling-time and
peak-tilt quantiles (p50, p95, p99) with distribution-free 95 % intervals
(failures count as never settled), and the worst cases with their indices.
Scenario i of seed S is the same whatever N, the batch size or the number of
workers: rerun it alone with --seed S --rerun i.

The position is sampled at --rate (default the certificate's rate, else 100 Hz)
and an NNI controller runs in discrete time at that rate (exact ZOH, as 'nniquad
export' writes it); the attitude loop, motors and altitude loop are continuous.

--within-certificate draws only inside what a schema-2 certificate's cascade
section certifies: mass, inertia, attitude-gain and motor time-constant
factors from cascade.box, the initial displacement from the disk of
cascade.region_of_attraction.max_displacement_m, the rate cascade.rate_hz, no
noise and no wind (the certificate covers neither); the range options cannot
be combined with it.  Every such scenario must converge: each failure is
printed with its index and the --rerun command that reproduces it, and the
exit status is 1.  A certificate without a cascade section certifies no box:
exit status 2.

Execution: a local process pool on all cores (--workers N), or an existing
Dask cluster (--scheduler tcp://host:port; start one with 'dask scheduler'
and 'dask worker tcp://host:8786 --nworkers N --nthreads 1', nniquad
installed on every worker; an unreachable scheduler fails within 5 s).
Same seed, same results on either.  Progress goes to stderr.

Nothing finished is lost.  Ctrl-C stops the study and keeps the finished
scenarios in FILE.partial.json (montecarlo-seedS.partial.json without
--json), marked "partial": true with the reason ("stopped"); a second Ctrl-C
while it saves is ignored; exit status 130.  SIGTERM (kill, timeout, a batch
scheduler ending the job) does the same, marked "terminated", exit status 143.
A fault -- a worker process that dies (local pool), a Dask batch whose workers
keep dying, a lost scheduler, or no batch finished for --stall-timeout seconds
(every worker gone, or hung) -- saves the same way and exits with status 4 and
a one-line message naming it.
A Dask worker that dies once is no fault: its batch runs again elsewhere.

--reference SPEC (a waypoint file, circle:R,T or figure8:AX,AY,T; with
--feedforward and --feedforward-lead S as for simulate): every scenario starts
on the reference with its velocity, displaced by its drawn displacement, and
follows it.  Settling does not apply: a scenario succeeds unless the vehicle is
lost, and the table gives the RMS tracking error's quantiles (failures count as
+inf) in place of the settling time's.  Not with --within-certificate: no
certificate covers a moving reference (docs/follow.md)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--certificate", metavar="FILE", required=True,
                        help="certificate JSON (checked: schema, version, SHA-256 digest)")
    parser.add_argument("--samples", type=int, default=1000, metavar="N", help="number of scenarios (default 1000)")
    parser.add_argument("--seed", type=int, default=0, metavar="S", help="seed of the study (default 0)")
    parser.add_argument("--horizon", type=float, default=20.0, metavar="T", help="simulated time in s (default 20)")
    parser.add_argument("--rerun", metavar="INDEX[,INDEX...]", default=None,
                        help="rerun only these scenario indices of --seed (in this process) and show them in detail")
    parser.add_argument("--rate", type=float, default=None, metavar="HZ",
                        help="control rate: the position is sampled at HZ and the NNI controller runs in discrete "
                             "time at HZ (default: the certificate's rate, cascade.rate_hz or margins.rate_hz, "
                             f"else {CONTROL_RATE_HZ:g})")
    add_delay_option(parser, None, "every scenario (default 0, with --within-certificate the certificate's "
                                   "certified delay_samples); beyond the certified delay it is flagged, and "
                                   "refused with --within-certificate")
    parser.add_argument("--within-certificate", action="store_true",
                        help="draw only inside what the certificate certifies (its cascade section: parameter box, "
                             "region of attraction, rate; no noise, no wind); every scenario must converge, "
                             "exit status 1 if one does not")
    x = parser.add_argument_group("execution")
    x.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="Dask scheduler address, e.g. tcp://10.0.0.5:8786 (default: local process pool)")
    x.add_argument("--workers", type=int, default=None, metavar="N",
                   help=f"local worker processes (default: usable CPUs, {usable_cpu_count()} here; 1 runs in-process)")
    x.add_argument("--batch-size", type=int, default=None, metavar="N",
                   help="scenarios per batch, the unit of work (default: about 4 batches per worker, at most 50)")
    x.add_argument("--stall-timeout", type=float, default=None, metavar="S",
                   help=f"stop (and save what finished) when no batch has finished for S seconds on the pool or "
                        f"cluster (default {MC_STALL_TIMEOUT_S:g}; inf waits for ever)")
    r = parser.add_argument_group("perturbation ranges (uniform)")
    r.add_argument("--mass-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="true mass / nominal (default 0.8 1.2)")
    r.add_argument("--inertia-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="true inertia / nominal, per axis (default 0.8 1.2)")
    r.add_argument("--attitude-gain-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="factor on the attitude-loop torques (default 0.7 1.3)")
    r.add_argument("--tau-motor-factor-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="motor time constant / the vehicle's nominal (default 0.5 2)")
    r.add_argument("--tau-motor-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="absolute motor time constant range in s, instead of the factor (default: off)")
    r.add_argument("--noise-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="position-noise sigma in m, sampled at 100 Hz (default 0 0.02)")
    r.add_argument("--wind-fraction-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="constant wind force as a fraction of the nominal weight m g, random direction "
                        "(default 0 0.06)")
    r.add_argument("--wind-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="constant wind force magnitude in N instead of the fraction (absolute)")
    r.add_argument("--max-displacement", type=float, default=None, metavar="M",
                   help="cap on the initial displacement radius in m (default 5)")
    r.add_argument("--altitude-limit", type=float, default=None, metavar="M",
                   help="altitude deviation counted as divergence, in m (default 2)")
    add_reference_options(parser.add_argument_group("reference (default: return to the origin)"), single_run=False)
    parser.add_argument("--worst", type=int, default=10, metavar="K", help="worst cases to list (default 10)")

    add_output_option(parser, "--json", metavar="FILE", default=None,
                        help="write the summary and every scenario's result as JSON to FILE")


_RANGE_OPTIONS = (
    ("mass_range", "mass_factor", "--mass-range"),
    ("inertia_range", "inertia_factor", "--inertia-range"),
    ("attitude_gain_range", "attitude_gain_factor", "--attitude-gain-range"),
    ("tau_motor_factor_range", "tau_motor_factor", "--tau-motor-factor-range"),
    ("tau_motor_range", "tau_motor_s", "--tau-motor-range"),
    ("noise_range", "noise_sigma_m", "--noise-range"),
    ("wind_fraction_range", "wind_weight_fraction", "--wind-fraction-range"),
    ("wind_range", "wind_N", "--wind-range"),
    ("max_displacement", "max_displacement_m", "--max-displacement"),
    ("altitude_limit", "altitude_limit_m", "--altitude-limit"),
)


def _ranges(args: argparse.Namespace, cert: Any = None):
    """The ranges of the study and, with --within-certificate, the certified region [m] (else ``None``)."""
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.sim.options import check_rate_hz
    from nniquad.scenarios.ranges import certified_delay_samples
    from nniquad.study import MonteCarloError, ScenarioRanges, certificate_rate_hz, within_certificate_ranges

    given = [flag for attr, _, flag in _RANGE_OPTIONS if getattr(args, attr) is not None]
    delay, certified = delay_samples(args), certified_delay_samples(cert)
    if args.within_certificate:
        if given:
            raise MonteCarloError(f"--within-certificate takes its ranges from the certificate: drop {given[0]}")
        if args.rate is not None:
            raise MonteCarloError("--within-certificate runs at the certificate's rate: drop --rate")
        ranges, region, rate = within_certificate_ranges(cert)
        check_rate_hz(rate, error=MonteCarloError, option="the certificate's cascade.rate_hz")
        if delay is not None and delay != certified:
            raise MonteCarloError(f"--within-certificate: a measurement delay of {delay} samples is "
                                  + ("beyond the" if delay > certified else "not the")
                                  + f" certified delay ({certified} samples: the cascade section proves exactly it)")
        return (ranges if delay is None else ranges.with_(delay_samples=delay)), region
    changes: dict[str, Any] = {field: (tuple(v) if isinstance(v, list) else v)
                               for attr, field, _ in _RANGE_OPTIONS if (v := getattr(args, attr)) is not None}
    if delay is not None:
        changes["delay_samples"] = delay
    rate = certificate_rate_hz(cert) if args.rate is None else args.rate
    changes["noise_rate_hz"] = check_rate_hz(rate, error=MonteCarloError,
                                             option="--rate" if args.rate is not None else "the certificate's rate")
    return ScenarioRanges(**changes), None


def _rerun_hint(args: argparse.Namespace) -> str:
    parts = ["nniquad", "montecarlo", "--certificate", str(args.certificate), "--seed", str(args.seed)]
    if args.within_certificate:
        parts += ["--within-certificate"]
    if args.rate is not None:
        parts += ["--rate", f"{args.rate:g}"]
    if args.delay_samples is not None:
        parts += ["--delay-samples", str(args.delay_samples)]
    if args.horizon != 20.0:
        parts += ["--horizon", f"{args.horizon:g}"]
    for attr, _, flag in _RANGE_OPTIONS:
        v = getattr(args, attr)
        if v is not None:
            parts += [flag, *(f"{x:g}" for x in (v if isinstance(v, list) else [v]))]
    if args.reference is not None:
        parts += ["--reference", args.reference] + (["--feedforward"] if args.feedforward else [])
        parts += ["--feedforward-lead", f"{args.feedforward_lead:g}"] if args.feedforward_lead else []
    return " ".join(shlex.quote(p) for p in parts) + " --rerun INDEX"


def partial_path(json_path: str | None, seed: int) -> Path:
    """Where an interrupted study is saved: ``FILE.partial.json`` next to ``--json FILE``."""
    if json_path:
        p = Path(json_path)
        stem = p.name[:-5] if p.name.lower().endswith(".json") else p.name
        return p.with_name(stem + ".partial.json")
    return Path(f"montecarlo-seed{seed}.partial.json")


def _worker_threads(client: Any) -> dict[str, int]:
    try:
        return {str(k): int(v) for k, v in client.nthreads().items()}
    except Exception:  # noqa: BLE001 -- informational only
        return {}


def _positive(name: str, value: Any) -> None:

    if value is not None and value <= 0:
        raise MonteCarloError(f"{name} must be a positive integer, got {value}")


def _study_json(args, setup, ranges) -> dict[str, Any]:
    return {"certificate": str(args.certificate), "seed": args.seed, "samples": args.samples,
            "setup": setup.to_json(), "ranges": ranges.to_json()}


def _rerun(args: argparse.Namespace, setup, ranges) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.study import MonteCarloError, draw_scenario, run_scenarios

    try:
        indices = [int(v) for v in str(args.rerun).split(",") if v.strip()]
    except ValueError:
        raise MonteCarloError(f"--rerun takes scenario indices such as 7 or 3,17, got {args.rerun!r}") from None
    if not indices or any(i < 0 for i in indices):
        raise MonteCarloError(f"--rerun takes non-negative scenario indices, got {args.rerun!r}")
    scenarios = [draw_scenario(i, args.seed, ranges, setup) for i in indices]
    results = run_scenarios(scenarios)
    for r in results:
        print(f"scenario {r.index} of seed {r.study_seed}: {'success' if r.success else 'FAILURE: ' + str(r.failure)}")
        rows = [("settling time (to the setpoint)", r.settling_s, "s"),
                ("settling about wind equilibrium", r.settling_time_about_wind_equilibrium_s, "s"),
                ("peak tilt", r.peak_tilt_deg, "deg"),
                ("wind equilibrium offset", r.offset_m, "m"), ("steady offset (last 1 s)", r.steady_offset_m, "m"),
                ("final error from setpoint", r.final_error_m, "m"),
                ("commanded tilt RMS (hover)", r.tilt_command_rms_deg, "deg"),
                ("rotor command at a limit", None if r.rotor_limit_share is None else 100 * r.rotor_limit_share, "%"),
                ("max altitude deviation", r.max_altitude_dev_m, "m")]
        if r.tracking_rms_m is not None:
            rows += [("tracking RMS", r.tracking_rms_m, "m"), ("tracking max", r.tracking_max_m, "m")]
        for name, v, unit in rows:
            print(f"  {name:<30} {'-' if v is None else f'{v:.4g} {unit}'}")
        for k, v in r.scenario.items():
            shown = ", ".join(f"{x:.4g}" for x in v) if isinstance(v, list) else f"{v:.4g}"
            print(f"  {k:<30} {shown}")
    if args.json:
        atomic_write_json(args.json, {"study": _study_json(args, setup, ranges),
                                      "rerun": [r.to_json() for r in results]})
        print(f"wrote {args.json}", file=sys.stderr)
    if args.within_certificate:
        return _within_certificate_verdict(results, _rerun_hint(args))
    return 0


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.certificate import load_certificate
    from nniquad.study import (
        MonteCarloError,
        check_study_step,
        close_client,
        cluster_threads,
        connect_scheduler,
        study_setup,
    )

    if args.rerun is None:
        _positive("--samples", args.samples)
    _positive("--workers", args.workers)
    _positive("--batch-size", args.batch_size)
    if args.scheduler and args.workers is not None and args.rerun is None:
        raise MonteCarloError("--workers sets the local pool; with --scheduler the cluster's workers run the study")
    if args.worst < 0:
        raise MonteCarloError(f"--worst must not be negative, got {args.worst}")
    if args.seed < 0:
        raise MonteCarloError(f"--seed must be a non-negative integer, got {args.seed}")
    if not (math.isfinite(args.horizon) and args.horizon > 0):
        raise MonteCarloError(f"--horizon must be a positive number of seconds, got {args.horizon:g}")
    if args.stall_timeout is not None and not args.stall_timeout > 0:  # nan fails too
        raise MonteCarloError(f"--stall-timeout must be a positive number of seconds, got {args.stall_timeout:g}")
    if args.json is not None:
        # --json itself is checked by main; an interrupted study writes FILE.partial.json beside it
        check_output_paths([("--json", args.json), ("--json's partial file", partial_path(args.json, args.seed))])
    follow = {k: v for k, v in reference_settings(args).items() if k in ("reference", "feedforward", "feedforward_lead_s")}
    if follow and args.within_certificate:
        raise MonteCarloError("--reference cannot be combined with --within-certificate: no certificate covers a "
                              "moving reference")
    cert = load_certificate(args.certificate)
    ranges, region = _ranges(args, cert)
    delay = _delay_coverage(cert, ranges)
    if not delay.covered:
        print(f"[montecarlo] {delay.note('study')}", file=sys.stderr)
    setup = replace(study_setup(cert, ranges, horizon_s=args.horizon, region_m=region), **follow)
    # the RK4 step against the fastest scenario the ranges can draw (strongest attitude gain, fastest motor)
    check_study_step(setup, ranges,
                     hint={"attitude": "--attitude-gain-range", "motor lag": "--tau-motor-range or --tau-motor-factor-range"})
    if args.rerun is not None:
        return _rerun(args, setup, ranges)
    workers = 1 if args.scheduler else (args.workers or usable_cpu_count())
    check_estimate(montecarlo_estimate(args.samples, setup.horizon_s, setup.dt_s, setup.output_dt_s, workers),
                   option=" ".join([f"--samples {args.samples}"]
                                   + ([f"--horizon {args.horizon:g}"] if args.horizon != 20.0 else [])
                                   + ([f"--workers {args.workers}"] if args.workers is not None else [])),
                   error=MonteCarloError)

    from nniquad.jobs.montecarlo import montecarlo
    from nniquad.study import STOP_SIGNALS, StudyFailedError, catch_interrupts

    client = None
    if args.scheduler:
        client = connect_scheduler(args.scheduler)
    failure: StudyFailedError | None = None
    saved: Path | None = None
    try:
        if client is not None:
            threads = cluster_threads(client)
            where = f"Dask scheduler {args.scheduler} ({threads} worker thread(s))"
            if threads == 0:
                where += "; no worker has joined yet, waiting"
            elif any(n > 1 for n in _worker_threads(client).values()):
                print("[montecarlo] note: the simulator holds the GIL, so a Dask worker runs one scenario at a "
                      "time whatever its threads; start workers with --nworkers N --nthreads 1", file=sys.stderr)
        else:
            where = f"{args.workers or usable_cpu_count()} local worker(s)"
        progress = Progress("montecarlo")
        progress.note(f"{args.samples} scenarios of {setup.horizon_s:g} s on {where}")
        # From here until the finished scenarios are on disk, Ctrl-C or SIGTERM only asks the study to stop:
        # a second signal cannot cut the cancelling or the writing short.
        with catch_interrupts(signals=STOP_SIGNALS) as stop:
            try:
                result = montecarlo(setup, args.samples, args.seed, ranges=ranges, workers=args.workers,
                                    client=client, batch_size=args.batch_size, n_worst=args.worst,
                                    progress=progress.count, stall_timeout_s=args.stall_timeout, stop=stop,
                                    notify=progress.note)
            except StudyFailedError as exc:
                failure, result = exc, exc.result
            hint = _rerun_hint(args)
            data: dict[str, Any] = result.to_json()
            data["study"] = {"certificate": str(args.certificate), **data["study"],
                             "beyond_certified_delay": delay.beyond, "delay_covered": delay.covered}
            data["rerun"] = hint
            if result.partial:
                saved = _save_partial(partial_path(args.json, args.seed), data)
            elif args.json:  # a complete study is written under the same guard: a signal now cannot lose it
                atomic_write_json(args.json, data)
    finally:
        if client is not None:
            close_client(client)
    study = result.run
    progress.close("done" if not study.partial else study.stopped if failure is None else f"stopped ({failure.kind})")
    if result.summary is not None:
        print(f"certificate: {args.certificate}  {setup.label}")
        g = setup.base.gains
        print(f"gains: {gains_text(g)}   horizon {setup.horizon_s:g} s, "
              f"displacement up to {setup.region_m:.3g} m, settling band {setup.band_m:.3g} m")
        if ranges.delay_samples or not delay.covered:
            print(f"measurement delay: {ranges.delay_samples} samples at {ranges.noise_rate_hz:g} Hz"
                  + (f"; {delay.note('study')}" if not delay.covered else " (the certified delay)"))
        print(result.table(rerun_hint=hint))
        print(f"{study.executor}, {study.workers} worker(s), batches of {study.batch_size}: "
              f"{study.scenarios_per_s:.2f} scenarios/s")
    if study.partial:
        kept = (f"{len(study.results)} of {study.n_requested} scenarios finished, saved in {saved} "
                f"(marked \"partial\": true)")
        if failure is None:  # stopped by a signal
            print(f"nniquad montecarlo: {study.stopped}; {kept}", file=sys.stderr)
            return EXIT_TERMINATED if study.stopped == "terminated" else EXIT_INTERRUPTED
        if failure.kind == "error" and failure.__cause__ is not None:
            print(f"[montecarlo] {kept}", file=sys.stderr)
            raise failure.__cause__  # a bug: shown with its traceback
        print(f"nniquad montecarlo: error: {failure.reason}; {kept}", file=sys.stderr)
        return failure.exit_code
    if args.json:
        print(f"wrote {args.json}", file=sys.stderr)
    if args.within_certificate:
        return _within_certificate_verdict(study.results, hint)
    return 0


def _delay_coverage(cert: Any, ranges: Any):
    """Whether the certificate covers the study's measurement delay (a ``DelayCoverage``)."""
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.scenarios.ranges import DelayCoverage, certified_delay_samples

    return DelayCoverage(ranges.delay_samples, certified_delay_samples(cert))


def _within_certificate_verdict(results, hint: str) -> int:
    """Every scenario inside the certificate must converge: list each failure with its rerun command."""
    failed = [r for r in results if not r.success]
    for r in failed:
        print(f"FAILED within certificate: scenario {r.index} ({r.failure}); rerun: "
              f"{hint.replace('INDEX', str(r.index))}")
    print(f"within certificate: {len(results) - len(failed)}/{len(results)} converged")
    return 1 if failed else 0


def _save_partial(target: Path, data: dict[str, Any]) -> Path:
    """Write the finished scenarios to ``target``, or, if that fails, to the temporary folder."""
    try:
        return atomic_write_json(target, data)
    except OSError as exc:
        import tempfile

        fallback = Path(tempfile.gettempdir()) / target.name
        print(f"[montecarlo] cannot write {target} ({exc.strerror or exc}); saving in {fallback}", file=sys.stderr)
        return atomic_write_json(fallback, data)
