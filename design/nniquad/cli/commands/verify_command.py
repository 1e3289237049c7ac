"""``nniquad verify``: re-check a certificate independently."""

from __future__ import annotations

import argparse

from nniquad.cli.commands.common import add_json_option, write_json_if_asked

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run"]

HELP = "independently re-check a certificate"
DESCRIPTION = """Recompute everything a certificate states, from its own vehicle and gains.

Checks, cheap first: the digest (SHA-256 of the canonical content: a checksum
anyone can recompute, so it shows the file is unchanged since it was last
signed, not who signed it); the model name; the tolerances (must be the
library's); the layout of every section and its stated forms; the reference
runs' settings and every stated tilt limit; the sector inequality and the
smallest gamma; the closed-loop poles, damping and decay rate; the eigenvalues
of every P and of every Lyapunov / dissipation expression (plant and
controller NI certificates, closed-loop decay, the parameter-dependent P over
the mass interval on a 201-point grid, the region-of-attraction decrease and
inclusion conditions and the certified reach); the time-optimal bound and the
ratios to it; the classical margins; the tracking-error bound (a 'tracking'
section, recomputed by nniquad.analysis.tracking_section; a certificate without
one is noted 'tracking: not stated'); a schema-2 cascade section (rebuilt by
nniquad.analysis.cascade.box_certificate); and a re-simulation of the reduced and full
reference runs that must reproduce the stated settling time, overshoot, peak
tilt and diverged flag within the certificate's tolerances.

Every strict matrix inequality (P > 0, the NI storages, the closed-loop decay,
the robust-mass decay at its 201 masses, the region-of-attraction decrease, the
cascade's Lyapunov contraction at its LMI points, its grid points and over the
cells of its parameter box) is proven in floating point by a verified Cholesky
decomposition (Rump, BIT 46, 2006, Corollaries 2.4 and 2.7), and the small
reduced-loop ones again in exact rational arithmetic.  Each check's result is
'proven', 'pass' (numbers recomputed within tolerance, no inequality), 'FAIL'
or 'NOT PROVEN' (nothing fails, but a margin is below what floating point can
prove; never a pass).  --json gives, per check, its outcome, method
(verified-cholesky, exact, recomputed), smallest proven margin and every proof.

A result says whether the certificate states the truth, not whether the design
meets a requirement: the column 'requirement' (JSON 'requirement_met') says that,
for the checks that state one (the classical margins GM >= 6 dB and PM >= 45 deg,
the start inside every certified region, the start inside the cascade's region,
the sector bound of the paper class): 'met', 'NOT MET' (truly stated, and not
met) or '-' (no requirement).  The exit status follows the results only.

Prints one row per check, then notes: what a schema-1 certificate does not
cover, and which fields (software, tuning, the vehicle's name) are unverified
records.  Exit status: 0 when every check is proven or passes; 1 when a check fails or
is not proven,
including a digest that does not match the content (a certificate changed
after signing), with the failed check named; 2 when the file cannot be read
as a certificate at all (unreadable, not UTF-8 JSON, wrong schema or version,
a schema version that disagrees with the cascade section, a missing or
malformed field), with a one-line reason."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("certificate", metavar="CERT.json", help="certificate file written by 'nniquad certify'")
    parser.add_argument("--no-simulate", action="store_true",
                        help="skip the re-simulation (matrix and digest checks only)")
    parser.add_argument("--fail-fast", action="store_true", help="stop at the first failed check")
    parser.add_argument("--thorough", action="store_true",
                        help="also prove the cascade's Lyapunov inequality over every cell of its parameter box (the "
                             "continuum between the grid points; several seconds to a minute per certificate)")
    add_json_option(parser, "per-check results")


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates import read_certificate
    from nniquad.jobs.certify import verify

    cert = read_certificate(args.certificate)
    result = verify(cert, simulate=not args.no_simulate, fail_fast=args.fail_fast, thorough=args.thorough)
    print(result.table())
    write_json_if_asked(args, result.to_json())
    unmet = [c.name for c in result.checks if c.requirement_met is False]
    if result.ok:
        print(f"certificate {args.certificate}: all {len(result.checks)} checks pass (every statement recomputed)"
              + (f"; requirements NOT MET, as truly stated: {', '.join(unmet)}" if unmet else
                 "; every requirement checked is met"))
        return 0
    bad = result.first_failure
    verdict = "NOT PROVEN" if result.outcome == "not proven" else "FAILED"
    print(f"certificate {args.certificate}: {verdict} ({bad.name}: {bad.detail})")
    return 1
