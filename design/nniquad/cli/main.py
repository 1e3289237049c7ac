"""The ``nniquad`` command line.

Each sub-command lives in its own module under :mod:`nniquad.cli.commands` and
exposes ``HELP`` (one line), ``DESCRIPTION`` (the ``--help`` text),
``add_arguments(parser)`` and ``run(args) -> int``.  Modules are imported only
when their command runs, so ``nniquad --help`` stays fast.

Exit status, the same for every command (:data:`EXIT_STATUS_HELP`, printed by
``nniquad --help``)::

    0    done; every check the command ran passed
    1    a check ran and failed: 'verify' found a recomputed number that does
         not match, an inequality refuted or not proven, or a certificate
         whose digest does not match its content
         (wherever a certificate is read); 'prove --strict' found a claim that
         does not hold; 'certify'/'report' issued a certificate that failed its
         own verification (nothing is written)
    2    a user error: a bad option or value, an unreadable or malformed input
         file, an output path that cannot be written, a request too large for
         this machine; nothing is written and no work is started
    3    an internal error (a bug in nniquad); the only case with a traceback
    4    'montecarlo' only: the study was stopped by a fault of where it ran (a
         worker or the scheduler died, the cluster made no progress); its
         finished scenarios are saved, marked partial
    130  interrupted (Ctrl-C); 'montecarlo' keeps its finished batches
    143  terminated (SIGTERM), handled like Ctrl-C: 'montecarlo' keeps its
         finished batches, every other command stops cleanly (no traceback,
         no partial file); see :mod:`nniquad.termination`

Every error ends in one line on stderr, ``nniquad COMMAND: error: ...``; a mistyped
option or sub-command gets the nearest known one in the same line (``did you
mean '--box-scale'?``, :func:`suggestion`), exit status 2 as for every usage error.
Output paths declared by a command (``--json``, ``--out``, ...) are checked
before its work starts.

A cold start stays cheap: ``nniquad --help`` (or no command) imports no command
module, and a command process runs with one BLAS thread unless
``OPENBLAS_NUM_THREADS`` / ``MKL_NUM_THREADS`` is set (:func:`_single_threaded_blas`).
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import importlib.util
import os
import re
import sys
import traceback
from typing import Sequence

from nniquad import __version__
from nniquad.cli.commands.common import check_declared_outputs
from nniquad.errors import (
    EXIT_CHECK_FAILED,
    EXIT_INTERNAL_ERROR,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_STUDY_FAILED,
    EXIT_TERMINATED,
    EXIT_USER_ERROR,
    NniquadError,
    Terminated,
)
from nniquad.termination import sigterm_as_interrupt, termination_requested

__all__ = ["main", "COMMANDS", "build_parser", "EXIT_STATUS_HELP", "suggestion"]

#: The exit-status scheme, shown at the end of every ``--help``.
EXIT_STATUS_HELP = (
    f"exit status: {EXIT_OK} done (every check passed); {EXIT_CHECK_FAILED} a check failed or was not proven (verify, a certificate "
    f"digest mismatch, prove --strict, simulate --certificate not reproducing its run); {EXIT_USER_ERROR} user error (bad option, input file or output path, "
    f"request too large; nothing written); {EXIT_INTERNAL_ERROR} internal error (a bug, with traceback); "
    f"{EXIT_STUDY_FAILED} montecarlo stopped by a fault of its workers or cluster (finished scenarios saved); "
    f"{EXIT_INTERRUPTED} interrupted (Ctrl-C); {EXIT_TERMINATED} terminated (SIGTERM, handled like Ctrl-C)."
)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (exit status 2), like every other user error, with the
    nearest option or sub-command when one was mistyped (Python 3.11's argparse has no ``suggest_on_error``)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        message = " ".join(str(message).split())
        hint = suggestion(message, self.option_strings())
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {message}{hint} (see '{self.prog} --help')\n")

    def option_strings(self) -> list[str]:
        """Every option of this parser and of its built sub-commands (an unrecognised argument of a sub-command is
        reported by the top-level parser; only the command that runs has its options built)."""
        found: list[str] = []
        # argparse (3.11) has no public list of a parser's actions: _actions is the one it keeps
        for action in self._actions:
            found += [o for o in action.option_strings if o.startswith("--")]
            choices = action.choices if isinstance(action.choices, dict) else {}  # the sub-command parsers
            for sub in choices.values():
                if isinstance(sub, _Parser):
                    found += sub.option_strings()
        return list(dict.fromkeys(found))


#: How close a mistyped word must be to a known one to be suggested (:func:`difflib.get_close_matches`'s cutoff).
SUGGESTION_CUTOFF = 0.6


def suggestion(message: str, options: Sequence[str]) -> str:
    """``"; did you mean '--box-scale'?"`` for an argparse error about a mistyped option (one of ``options``) or
    choice (a sub-command, a ``--controller`` name, ...), or ``""`` when nothing known is close.

    Parameters
    ----------
    message
        argparse's error message (one line).
    options
        The known long options.
    """
    unknown = re.match(r"unrecognized arguments: (.*)", message)
    if unknown:
        for token in unknown.group(1).split():
            if token.startswith("--"):
                close = difflib.get_close_matches(token.split("=", 1)[0], options, n=1, cutoff=SUGGESTION_CUTOFF)
                if close:
                    return f"; did you mean '{close[0]}'?"
        return ""
    choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
    if choice:
        choices = re.findall(r"'([^']*)'", choice.group(2))
        close = difflib.get_close_matches(choice.group(1), choices, n=1, cutoff=SUGGESTION_CUTOFF)
        if close:
            return f"; did you mean '{close[0]}'?"
    return ""

#: sub-command name -> (module under nniquad.cli.commands, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "derive": ("derive_command", "print the symbolic vehicle model (LaTeX, Markdown or JSON)"),
    "vehicle": ("vehicle_command", "show or write a vehicle parameter file, with units"),
    "prove": ("prove_command", "audit every claim of the paper: verdict, evidence, correction"),
    "lmi": ("lmi_command", "solve the NI, SNI, closed-loop and region-of-attraction LMIs"),
    "simulate": ("simulate_command", "simulate the closed loop on the linear, reduced or full model"),
    "bound": ("bound_command", "time-optimal lower bound on settling under the tilt limit"),
    "tune": ("tune_command", "find the fastest gain set the NI theory certifies"),
    "certify": ("certify_command", "tune, then write a certified gain set (JSON)"),
    "verify": ("verify_command", "independently re-check a certificate"),
    "montecarlo": ("montecarlo_command", "Monte Carlo robustness study of a certificate"),
    "report": ("report_command", "the main job: audit, certificate, figures and report.md"),
    "export": ("export_command", "write the certified controller as state-space JSON or C99 code"),
}


def _available_commands() -> dict[str, tuple[str, str]]:
    """Commands whose module exists in this installation."""
    found = {}
    for name, (module, help_) in COMMANDS.items():
        if importlib.util.find_spec(f"nniquad.cli.commands.{module}") is not None:
            found[name] = (module, help_)
    return found


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Build the argument parser; only ``command``'s module is imported (all when ``None``, none when ``""``)."""
    parser = _Parser(
        prog="nniquad",
        epilog=EXIT_STATUS_HELP,
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
            epilog=EXIT_STATUS_HELP,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


#: BLAS thread pools capped to one thread in a command-line process (unless the user set them).
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _single_threaded_blas() -> None:
    """One BLAS thread for this process and its workers, unless the environment says otherwise.

    Every matrix of nniquad is small (at most a few dozen states, in stacks of
    thousands); a second BLAS thread on one of them only adds synchronisation,
    which on a loaded 2-core machine costs more than the work (a cold
    ``verify``'s stacked matrix exponentials took seconds instead of a tenth of
    one).  The variables are read when numpy loads, so this runs before any
    command module is imported; in a process that already imported numpy it
    changes nothing.
    """
    if "numpy" in sys.modules:
        return
    for var in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(var, "1")


def _one_line(text: object) -> str:
    """A message as one line (a newline in a user's file name must not split it)."""
    return " ".join(str(text).split()) or "(no message)"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status (see the module docstring)."""
    _single_threaded_blas()
    with sigterm_as_interrupt():
        try:
            return _main(argv)
        except Terminated:  # before a command had started
            print("nniquad: terminated", file=sys.stderr)
            return EXIT_TERMINATED


def _main(argv: Sequence[str] | None) -> int:
    args_list = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in args_list if not a.startswith("-")), None)
    if command not in COMMANDS:
        command = ""  # no command (or an unknown one): the sub-command list needs no command module
    parser = build_parser(command)
    args = parser.parse_args(args_list)
    if not getattr(args, "command", None):
        parser.print_help()
        return EXIT_OK
    name = f"nniquad {args.command}"

    def fail(message: object, code: int = EXIT_USER_ERROR) -> int:
        if termination_requested():  # the failure is the SIGTERM, told by a library in its own words
            return terminated()
        print(f"{name}: error: {_one_line(message)}", file=sys.stderr)
        return code

    def terminated() -> int:
        print(f"{name}: terminated", file=sys.stderr)
        return EXIT_TERMINATED

    try:
        check_declared_outputs(args)  # every output path, before any work
        return int(args._run(args) or 0)
    except NniquadError as exc:
        return fail(exc, getattr(exc, "exit_code", EXIT_USER_ERROR))
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (Terminated; CasADi makes it a plain KeyboardInterrupt)
        if isinstance(exc, Terminated) or termination_requested():
            return terminated()
        print(f"{name}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except MemoryError:
        return fail("not enough memory for this request (reduce the horizon, samples or batch size)")
    except RecursionError:
        return fail("input nested too deeply to process")
    except BrokenPipeError:
        # the reader of our output went away (nniquad ... | head): not an error of ours
        try:
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 -- silence the flush at exit
        except OSError:
            pass
        return EXIT_OK
    except OSError as exc:
        # a file system problem on a path the user gave (disk full, permission, removed folder, ...)
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        return fail(f"{where}{exc.strerror or exc}")
    except Exception:  # noqa: BLE001 -- anything else is a bug: say so, with the traceback
        if termination_requested():
            return terminated()
        traceback.print_exc()
        return fail("internal error (a bug in nniquad; please report it with the traceback above)",
                    EXIT_INTERNAL_ERROR)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
