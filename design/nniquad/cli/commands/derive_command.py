"""``nniquad derive``: print the symbolic vehicle model."""

from __future__ import annotations

import argparse
import sys

from nniquad.cli.commands.common import add_output_option
from nniquad.io import atomic_write_text

HELP = "print the symbolic vehicle model (LaTeX, Markdown or JSON)"
DESCRIPTION = """Print the vehicle model derived with sympy from the Lagrangian.

Frame: inertial NED (z down), body FRD, thrust u1 along -z_B, ZYX Euler angles
(the frame of the paper's f(x, u)); the z-up form of the translational dynamics
is printed too.  State order is the paper's:
x = [x, x', y, y', z, z', phi, phi', theta, theta', psi, psi'].

Variants:
  exact   T_rot = 1/2 w^T J w with body rates w = W(eta) eta'  (M(eta) = W^T J W,
          Coriolis matrix from Christoffel symbols, rotor gyroscopic torque)
  paper   the paper's stated T_rot = 1/2 eta'^T J eta' (M = J, C = 0)

Formats: markdown (default), latex, json (sympy srepr-free plain strings)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--variant", choices=("exact", "paper"), default="exact", help="rotational kinetic energy used (default: exact)")
    parser.add_argument("--format", choices=("markdown", "latex", "json"), default="markdown", help="output format (default: markdown)")

    add_output_option(parser, "--out", metavar="FILE", default=None, help="write to FILE instead of standard output")


def run(args: argparse.Namespace) -> int:
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.model.derivation import derive

    print("deriving the model with sympy ...", file=sys.stderr, flush=True)
    text = derive(args.variant).render(args.format)
    if args.out:

        atomic_write_text(args.out, text + "\n")
        print(f"wrote {args.out}", file=sys.stderr)
    else:
        print(text)
    return 0
