"""Options and helpers shared by several sub-commands."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from nniquad.errors import GainError
from nniquad.io import atomic_write_json, check_output_folder, check_output_paths
from nniquad.validate import finite_number
from nniquad.model.vehicle import Vehicle, load_vehicle

__all__ = ["add_tilt_limit_option", "add_xi0_option", "add_vehicle_option", "vehicle_from_args", "add_json_option",
           "write_json_if_asked", "finite_positive", "add_output_option", "check_declared_outputs", "declared_outputs"]


def add_output_option(parser: argparse.ArgumentParser, *flags: str, kind: str = "file",
                      group: Any = None, **kwargs: Any) -> argparse.Action:
    """Add an option naming an output (``kind`` ``"file"`` or ``"folder"``) and declare it.

    :func:`nniquad.cli.main.main` checks every declared output of the command
    (:func:`check_declared_outputs`) before the command's work starts, so a
    run of minutes never ends in an unwritable path.
    """
    if kind not in ("file", "folder"):
        raise ValueError(f"kind must be 'file' or 'folder', got {kind!r}")
    action = (group or parser).add_argument(*flags, **kwargs)
    declared = list(parser.get_default("_outputs") or [])
    declared.append((action.option_strings[0] if action.option_strings else action.dest, action.dest, kind))
    parser.set_defaults(_outputs=declared)
    return action


def declared_outputs(args: argparse.Namespace) -> list[tuple[str, str, str]]:
    """``(flag, dest, kind)`` of the outputs the command declared with :func:`add_output_option`."""
    return list(getattr(args, "_outputs", None) or [])


def check_declared_outputs(args: argparse.Namespace, extra: list[tuple[str, Any]] | None = None) -> None:
    """Check every declared output path given on the command line (and ``extra`` ``(label, path)`` pairs).

    Raises
    ------
    nniquad.errors.OutputError
        One line naming the option and the problem; nothing is created.
    """
    files = [(flag, getattr(args, dest, None)) for flag, dest, kind in declared_outputs(args) if kind == "file"]
    check_output_paths(files + list(extra or []))
    for flag, dest, kind in declared_outputs(args):
        if kind == "folder" and getattr(args, dest, None) is not None:
            check_output_folder(getattr(args, dest), option=flag)


def add_vehicle_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--vehicle FILE`` (TOML or JSON; default: the paper's vehicle)."""
    parser.add_argument(
        "--vehicle",
        metavar="FILE",
        default=None,
        help="vehicle parameter file (.toml or .json, fields as in 'nniquad vehicle'); default: the paper's vehicle",
    )


def vehicle_from_args(args: argparse.Namespace) -> Vehicle:
    """The vehicle named by ``--vehicle`` (validated)."""
    return load_vehicle(getattr(args, "vehicle", None))


def add_tilt_limit_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--tilt-limit DEG`` (default :data:`nniquad.config.TILT_LIMIT_DEG`), the one spelling of the tilt limit."""
    from nniquad.config import TILT_LIMIT_DEG

    parser.add_argument("--tilt-limit", type=float, default=TILT_LIMIT_DEG, metavar="DEG",
                        help=f"tilt limit in degrees, strictly between 0 and 90 (default {TILT_LIMIT_DEG:g})")


def add_xi0_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--xi0 X Y`` (default :data:`nniquad.config.XI0_M`), the initial horizontal position at rest."""
    from nniquad.config import XI0_M

    parser.add_argument("--xi0", type=float, nargs=2, default=list(XI0_M), metavar=("X", "Y"),
                        help=f"initial horizontal position in m, at rest (default {XI0_M[0]:g} {XI0_M[1]:g})")


def add_json_option(parser: argparse.ArgumentParser, what: str = "results") -> None:
    """Add ``--json FILE``."""
    add_output_option(parser, "--json", metavar="FILE", default=None, help=f"also write the {what} as JSON to FILE")


def write_json_if_asked(args: argparse.Namespace, data: Any) -> None:
    """Write ``data`` atomically to ``args.json`` when it was given, and say where."""
    path = getattr(args, "json", None)
    if path:
        atomic_write_json(path, data)
        print(f"wrote {Path(path)}", file=sys.stderr)


def finite_positive(name: str, value: float) -> float:
    """Return ``value`` as float, or raise :class:`GainError` naming ``name``."""
    return finite_number(name, value, error=GainError, positive=True)


def dumps(data: Any) -> str:
    """Indented JSON text."""
    return json.dumps(data, indent=2)
