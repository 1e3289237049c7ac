"""``nniquad report``: the main job."""

from __future__ import annotations

import argparse
from pathlib import Path

from nniquad.cli.commands.common import add_output_option, add_vehicle_option, finite_positive, vehicle_from_args
from nniquad.config import GAMMA_MAX
from nniquad.errors import GainError
from nniquad.laws.classes import DEFAULT_LAW_CLASS, LAW_CLASSES
from nniquad.progress import Progress

HELP = "the main job: audit, certificate, figures and report.md"
DESCRIPTION = """Run the whole design study on one vehicle and write one folder:

  report.md          audit table, certified gain set with its verification table,
                     figures, the time-optimal bound and the ratio to it,
                     key trade-off numbers
  report.json        every number report.md prints
  certificate.json   the certified gain set (check it with 'nniquad verify')
  audit.json/.md     the claim-by-claim audit of the paper
  paper_gains.png    the paper's gains on the linear, reduced and full models
  certified_gains.png  the certified gains on the same three models
  manifest.json      the SHA-256 of every file above

Every option is checked before any work starts.  The folder is built beside
--out and swapped in whole when everything is written: running it again
into the same folder replaces the old results cleanly, a failed or
interrupted run leaves the old folder as it was, and a second run into the
same folder while one is running is refused.  Only files an earlier run wrote
(listed, unchanged, in its manifest.json) are ever deleted; other files in
the folder are kept, and a file of yours with the name of a report output
makes the run refuse to start.

With --certificate FILE the report is written for an issued certificate
instead: nothing is tuned or certified, the certificate is verified (every
check recomputed; one that fails is refused, exit 1, nothing written), and
its vehicle, gains and inner loops are the report's.  The tuning options
(--vehicle, --model, --gamma-max, --roa-radius, --budget, --reruns,
--nominal, --law-class) do not apply to it and are refused with it."""

#: The tuning options, each with the keyword of :func:`nniquad.jobs.report.report` it sets.  They are parsed
#: with the default ``None`` (``False`` for --nominal): a report on a given --certificate can tell that one was
#: given and refuse it, and an option not given takes the default of ``report`` itself.
TUNING_OPTIONS = {"vehicle": "vehicle", "model": "model", "gamma_max": "gamma_max", "roa_radius": "roa_radius_m",
                  "budget": "budget", "reruns": "reruns", "nominal": "objective", "law_class": "law_class"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_vehicle_option(parser)
    add_output_option(parser, "--out", kind="folder", metavar="DIR", default="out", help="output folder (default: out)")
    parser.add_argument("--certificate", metavar="FILE", default=None,
                        help="report on this issued certificate instead of tuning and certifying (it is verified; "
                             "its vehicle, gains and inner loops are the report's)")
    parser.add_argument("--model", choices=("full", "reduced"), default=None,
                        help="model the certified gains are tuned on (default: full)")
    parser.add_argument("--gamma-max", type=float, default=None,
                        help=f"sector-bound ceiling gamma_max in (0, 1) (default {GAMMA_MAX:g}, the paper's)")
    parser.add_argument("--roa-radius", type=float, default=None, metavar="R",
                        help="certified reach the tuner demands, in m (default: |xi_h(0)| = 2.5 m; 0 switches it off)")
    parser.add_argument("--budget", choices=("quick", "normal", "thorough"), default=None,
                        help="tuning budget (default: normal; quick for a fast look)")
    parser.add_argument("--reruns", type=int, default=None, metavar="K",
                        help="extra tuner seeds for the grid-artefact check (default 1)")
    parser.add_argument("--nominal", action="store_true",
                        help="tune on the nominal scenario only (default for --model full: the robust objective, "
                             "p95 settling over the fixed tuning scenario set)")

    parser.add_argument("--law-class", choices=tuple(LAW_CLASSES), default=None,
                        help=f"class of the certified design: paper (the sector bound holds; Theorem main_result) or "
                             f"cascade (no sector bound; the sampled-data cascade certificate alone; its reduced-loop "
                             f"reach is then not demanded unless --roa-radius is given) (default {DEFAULT_LAW_CLASS})")


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.jobs.report import report

    # "is", not "in (None, False)": --reruns 0 and --roa-radius 0 are given (0 == False)
    given = {k: getattr(args, k) for k in TUNING_OPTIONS
             if getattr(args, k) is not None and getattr(args, k) is not False}
    if args.certificate is not None and given:
        raise GainError(f"{', '.join('--' + k.replace('_', '-') for k in given)}: a tuning option, which does not "
                        "apply to a report on a given --certificate (its vehicle, gains and inner loops are the "
                        "certificate's)")
    kwargs = {TUNING_OPTIONS[k]: v for k, v in given.items() if k not in ("vehicle", "nominal")}
    if args.certificate is not None:
        kwargs["certificate"] = args.certificate
    else:
        kwargs["vehicle"] = vehicle_from_args(args)
        if args.nominal:
            kwargs["objective"] = "nominal"
    if "gamma_max" in kwargs and not (0.0 < kwargs["gamma_max"] < 1.0):
        raise GainError(f"--gamma-max must be in (0, 1), got {kwargs['gamma_max']}")
    if kwargs.get("roa_radius_m") not in (None, 0):
        finite_positive("--roa-radius", kwargs["roa_radius_m"])
    out = Path(args.out)
    progress = Progress("report")
    data = report(out, progress=progress.stage, **kwargs).data
    progress.close()
    print(f"report written to {out.resolve()} in {data['wall_time_s']:.1f} s:")
    for name in data["files"]:
        print(f"  {out / name}")
    return 0
