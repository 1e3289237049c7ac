"""Options and helpers shared by several sub-commands."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from nniquad.errors import GainError
from nniquad.io import atomic_write_json
from nniquad.validate import finite_number
from nniquad.model.vehicle import Vehicle, load_vehicle

__all__ = ["add_tilt_limit_option", "add_xi0_option", "add_vehicle_option", "vehicle_from_args", "add_json_option", "write_json_if_asked", "finite_positive"]


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
    parser.add_argument("--json", metavar="FILE", default=None, help=f"also write the {what} as JSON to FILE")


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
