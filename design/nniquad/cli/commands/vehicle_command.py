"""``nniquad vehicle``: show a vehicle with units, or write an editable template."""

from __future__ import annotations

import argparse

from nniquad.cli.commands.common import add_output_option, add_vehicle_option, vehicle_from_args
from nniquad.io import atomic_write_text
from nniquad.model.vehicle import vehicle_to_toml

HELP = "show or write a vehicle parameter file, with units"
DESCRIPTION = """Show the vehicle parameters with units and derived ratios.

With --write FILE, write them as a TOML template (units as comments) that
--vehicle accepts on every command that simulates."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_vehicle_option(parser)
    add_output_option(parser, "--write", metavar="FILE.toml", default=None, help="write the vehicle as a TOML template")


def run(args: argparse.Namespace) -> int:
    vehicle = vehicle_from_args(args)
    print(vehicle.name)
    print(vehicle.describe())
    if args.write:
        atomic_write_text(args.write, vehicle_to_toml(vehicle))
        print(f"wrote {args.write}")
    return 0
