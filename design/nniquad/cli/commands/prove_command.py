"""``nniquad prove``: audit every claim of the paper (verdict, evidence, correction)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from nniquad.cli.commands.common import add_output_option
from nniquad.errors import NniquadError
from nniquad.io import atomic_write_json, atomic_write_text, output_transaction
from nniquad.resources import usable_cpu_count

HELP = "audit every claim of the paper: verdict, evidence, correction"
DESCRIPTION = """Audit the claims of Ghallab & Petersen's paper, one check per claim.

Each claim is checked literally as printed first (symbolic residuals for all
positive parameters where sympy can, LMIs with Clarabel re-checked by numpy,
exact linear responses, simulations of the full vehicle); where it fails, the
smallest correction is stated and checked by the same code.

Verdicts: holds | fails | holds-with-correction.

Prints a table (id, verdict, one-line reason).  --json writes
{"claims": [{"id", "paper_ref", "verdict", "statement", "evidence",
"counterexample", "correction", "method", ...}], "summary": {...}};
--markdown writes a report a reader can follow without running code.
The claims run in --workers processes (default: the usable CPUs), one paper
section per process at a time; the verdicts and evidence do not depend on it.

Exit status 0 when the audit ran, whatever the verdicts; with --strict, 1 when
any claim is not 'holds'; 2 on a usage error (e.g. an unknown claim id)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:

    add_output_option(parser, "--json", metavar="FILE", default=None, help="write the audit as JSON to FILE")
    add_output_option(parser, "--markdown", metavar="FILE", default=None, help="write the Markdown report to FILE")
    parser.add_argument("--only", metavar="ID,...", default=None,
                        help="comma-separated claim ids to run (default: all; see --list)")
    parser.add_argument("--list", action="store_true", help="list the claim ids and exit")
    parser.add_argument("--strict", action="store_true", help="exit 1 when any claim is not 'holds'")
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help="processes to run the claims in, one paper section each (default: the usable CPUs)")


def _ids(text: str | None) -> list[str] | None:
    """Claim ids of ``--only`` (validated by :func:`nniquad.proofs.audit.audit`)."""
    return None if text is None else [p.strip() for p in text.split(",") if p.strip()]


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.proofs.audit import audit
    from nniquad.proofs.claims import HOLDS, claim_ids


    if args.list:
        print("\n".join(claim_ids()))
        return 0
    if args.workers is not None and args.workers < 1:
        raise NniquadError(f"--workers must be a positive integer, got {args.workers}")
    results = audit(_ids(args.only), workers=args.workers or usable_cpu_count())
    print(results.table())
    with output_transaction():  # both files or neither
        if args.json:
            atomic_write_json(args.json, results.to_json())
        if args.markdown:
            atomic_write_text(args.markdown, results.markdown())
    for path in (args.json, args.markdown):
        if path:
            print(f"wrote {Path(path)}", file=sys.stderr)
    if args.strict and any(r.verdict != HOLDS for r in results):
        return 1
    return 0
