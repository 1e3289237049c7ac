"""``nniquad export``: write a certificate's discrete-time controller for a flight stack."""

from __future__ import annotations

import argparse

from nniquad.cli.commands.common import add_output_option
from nniquad.config import CONTROL_RATE_HZ
from nniquad.io import output_transaction

__all__ = ["HELP", "DESCRIPTION", "add_arguments", "run"]

HELP = "write the certified controller as state-space JSON or C99 code"
DESCRIPTION = """Write the discrete-time NNI controller of a certificate at a control rate.

--format json writes nniquad_controller.json: the matrices A, B, C, D (exact
zero-order-hold discretisation, units stated), the rate, the output stage
(tilt limit, tilt setpoints) and the spectral radius of the linearised sampled
cascade at that rate.  --format c writes PREFIX.c and PREFIX.h: a C99 API
(init, start, step, reset; int status) around one step of the law generated
by CasADi: measured position and setpoint in, tilt setpoints and g_z out.
Every public name carries the prefix (--prefix; default the law and the
certificate's short digest), so two exports link into one program.
--format crazyflie writes the same files and a Crazyflie out-of-tree
controller (PREFIX_crazyflie.c) that flies them.  Refuses with a one-line
reason if the rate is not positive, the prefix is not a C identifier, DIR
cannot be written, the certificate is not valid or the sampled cascade is
unstable at the rate."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.integrations.crazyflie import EXPORT_FORMATS

    parser.add_argument("certificate", metavar="CERT.json", help="certificate file written by 'nniquad certify'")
    parser.add_argument("--format", choices=EXPORT_FORMATS, default="json", help="output format (default json)")
    parser.add_argument("--prefix", metavar="NAME", default=None,
                        help="C prefix of every public name and of the files (default: <law>_<short digest>)")

    add_output_option(parser, "--out", kind="folder", metavar="DIR", required=True,
                      help="output folder (created if missing)")
    parser.add_argument("--rate", metavar="HZ", type=float, default=None,
                        help="control rate = position sample rate in Hz (default: the rate the certificate "
                             f"certifies; {CONTROL_RATE_HZ:g} for a schema-1 certificate, which certifies none)")


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.certificates.certificate import read_certificate
    from nniquad.certificates.export import certified_rate_hz
    from nniquad.integrations.crazyflie import export_for


    cert = read_certificate(args.certificate)
    with output_transaction():  # every file of the export, or none
        written = export_for(cert, args.out, args.format, args.rate, args.prefix)
    for path in written:
        print(f"wrote {path}")
    certified = certified_rate_hz(cert)
    if certified is None:
        print("note: this schema-1 certificate certifies no sampled-data rate; the controller was written at "
              f"{args.rate if args.rate is not None else CONTROL_RATE_HZ:g} Hz")
    elif args.rate is not None and args.rate != certified:
        print(f"note: written at {args.rate:g} Hz, but the certificate certifies {certified:g} Hz only")
    return 0
