"""The ``nniquad`` command line.

Each sub-command lives in its own module under :mod:`nniquad.cli.commands` and
exposes ``HELP`` (one line), ``DESCRIPTION`` (the ``--help`` text),
``add_arguments(parser)`` and ``run(args) -> int``.  Modules are imported only
when their command runs, so ``nniquad --help`` stays fast.

User errors (:class:`nniquad.errors.NniquadError`, bad files) end in a one-line
message on stderr and exit status 2; no traceback is shown for them.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from typing import Sequence

from nniquad import __version__
from nniquad.errors import NniquadError

__all__ = ["main", "COMMANDS", "build_parser"]

#: sub-command name -> (module under nniquad.cli.commands, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "derive": ("derive", "print the symbolic vehicle model (LaTeX, Markdown or JSON)"),
    "vehicle": ("vehicle", "show or write a vehicle parameter file, with units"),
    "prove": ("prove", "audit every claim of the paper: verdict, evidence, correction"),
    "lmi": ("lmi", "solve the NI, SNI, closed-loop and region-of-attraction LMIs"),
    "simulate": ("simulate", "simulate the closed loop on the linear, reduced or full model"),
    "bound": ("bound", "time-optimal lower bound on settling under the tilt limit"),
    "tune": ("tune", "find the fastest gain set the NI theory certifies"),
    "certify": ("certify", "tune, then write a certified gain set (JSON)"),
    "verify": ("verify", "independently re-check a certificate"),
    "montecarlo": ("montecarlo", "Monte Carlo robustness study of a certificate"),
    "report": ("report", "the main job: audit, certificate, figures and report.md"),
    "export": ("export", "write the certified controller as state-space JSON or C99 code"),
}


def _available_commands() -> dict[str, tuple[str, str]]:
    """Commands whose module exists in this installation."""
    found = {}
    for name, (module, help_) in COMMANDS.items():
        if importlib.util.find_spec(f"nniquad.cli.commands.{module}") is not None:
            found[name] = (module, help_)
    return found


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Build the argument parser; only ``command``'s module is imported (all when ``None``)."""
    parser = argparse.ArgumentParser(
        prog="nniquad",
        description=(
            "Velocity-free horizontal position control of a quadrotor by nonlinear "
            "negative-imaginary (NNI) theory: a checked derivation, an audit of the "
            "paper, LMIs, simulation, tuning and certified gain sets. "
            "Run 'nniquad COMMAND --help' for the options of a command."
        ),
    )
    parser.add_argument("--version", action="version", version=f"nniquad {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_) in _available_commands().items():
        if command is not None and name != command:
            sub.add_parser(name, help=help_, add_help=False)
            continue
        mod = importlib.import_module(f"nniquad.cli.commands.{module}")
        p = sub.add_parser(
            name,
            help=help_,
            description=getattr(mod, "DESCRIPTION", help_),
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in args_list if not a.startswith("-")), None)
    if command not in COMMANDS:
        command = None
    parser = build_parser(command)
    args = parser.parse_args(args_list)
    if not getattr(args, "command", None):
        parser.print_help()
        return 0
    try:
        return int(args._run(args) or 0)
    except NniquadError as exc:
        print(f"nniquad {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"nniquad {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
