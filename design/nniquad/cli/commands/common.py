"""Options and helpers shared by several sub-commands."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

from nniquad.config import CONTROL_RATE_HZ, TILT_LIMIT_DEG, XI0_M
from nniquad.errors import GainError, NniquadError
from nniquad.io import atomic_write_json, check_output_folder, check_output_paths
from nniquad.laws.base import field_unit
from nniquad.laws import integral_variant
from nniquad.laws.registry import LAWS, law_named
from nniquad.model.vehicle import Vehicle, load_vehicle
from nniquad.validate import finite_number

__all__ = ["add_tilt_limit_option", "add_xi0_option", "add_vehicle_option", "vehicle_from_args", "add_json_option",
           "write_json_if_asked", "finite_positive", "add_output_option", "check_declared_outputs", "declared_outputs",
           "gain_option", "add_controller_option", "add_gain_options", "gains_from_args", "law_gains", "step_hints",
           "add_delay_option", "delay_samples", "add_integral_option", "apply_integral"]


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

    parser.add_argument("--tilt-limit", type=float, default=TILT_LIMIT_DEG, metavar="DEG",
                        help=f"tilt limit in degrees, strictly between 0 and 90 (default {TILT_LIMIT_DEG:g})")


def add_xi0_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--xi0 X Y`` (default :data:`nniquad.config.XI0_M`), the initial horizontal position at rest."""

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


# ----------------------------------------------------------------------------- the laws' gains as options


def gain_option(name: str) -> str:
    """The command-line option of a gain field (``tau_f`` -> ``--tau-f``; ``Gamma`` stays ``--Gamma``).

    Parameters
    ----------
    name
        The gain's field name.
    """
    return "--" + name.replace("_", "-")


def _gain_fields() -> dict[str, list[tuple[str, Any]]]:
    """Every registered law's gain fields: ``{field name: [(law name, field), ...]}`` in registration order."""
    out: dict[str, list[tuple[str, Any]]] = {}
    for law in LAWS.values():
        for f in fields(law.gains_type):
            out.setdefault(f.name, []).append((law.name, f))
    return out


def add_controller_option(parser: Any, choices: tuple[str, ...], default: str, what: str) -> None:
    """``--controller LAW``: one of the registered laws ``choices`` (:mod:`nniquad.laws`), each with its title.

    Parameters
    ----------
    parser
        The parser or group.
    choices
        The laws the command takes.
    default
        The default law.
    what
        What the law is for, to open the help text ("horizontal law to tune").
    """
    titles = "; ".join(f"{name}: {LAWS[name].title}" for name in choices)
    parser.add_argument("--controller", choices=choices, default=default,
                        help=f"{what} (default {default}; {titles})")


def add_integral_option(parser: Any) -> None:
    """``--integral``: the integral variant of ``--controller`` (:func:`apply_integral`)."""
    parser.add_argument("--integral", action="store_true",
                        help="the integral variant of --controller (nni -> nni_i, sni2 -> sni2_i): an integrator on "
                             "the position error with back-calculation anti-windup, gain ki [1/s^3]; law class "
                             "cascade only (the paper's sector theorem does not apply)")


def apply_integral(args: argparse.Namespace) -> None:
    """Replace ``args.controller`` by its integral variant when ``--integral`` is given (idempotent).

    Raises
    ------
    NniquadError
        The law has no integral variant (one line).
    """
    if getattr(args, "integral", False):
        try:
            args.controller = integral_variant(law_named(args.controller)).name
        except ValueError as exc:
            raise NniquadError(str(exc)) from None


def add_gain_options(group: Any, laws: tuple[str, ...] | None = None) -> None:
    """One option per gain field of the registered laws (``--kp``, ``--Gamma``, ``--k``, ``--tau-f``, ...), each
    with its unit and the laws it belongs to (:func:`gains_from_args` reads them).

    Parameters
    ----------
    group
        The parser or argument group.
    laws
        The laws whose gains are options (default every registered law).
    """
    for name, owners in _gain_fields().items():
        owners = [(law, f) for law, f in owners if laws is None or law in laws]
        if not owners:
            continue
        unit, meaning = field_unit(owners[0][1])
        group.add_argument(gain_option(name), dest=name, default=None, metavar="X",
                           help=f"{meaning} [{unit}] ({', '.join(law for law, _ in owners)})")


def law_gains(args: argparse.Namespace, law: Any) -> Any:
    """The law's gains from the command line, its default gains filling what is not given (the paper's for the NNI
    law); a law without defaults needs all its gains.

    Parameters
    ----------
    args
        The parsed arguments.
    law
        The law.

    Raises
    ------
    NniquadError
        As :func:`gains_from_args`, or no gains given for a law without defaults.
    """
    gains = gains_from_args(args, law, defaults=law.default_gains)
    if gains is None:
        if law.default_gains is None:
            raise NniquadError(f"the {law.name} law has no default gains: give "
                               f"{', '.join(gain_option(n) for n in law.gain_names)}")
        return law.default_gains
    return gains


def gains_from_args(args: argparse.Namespace, law: Any, *, defaults: Any = None) -> Any:
    """The gains of ``law`` given on the command line, or ``None`` when none is given.

    Parameters
    ----------
    args
        The parsed arguments (the options of :func:`add_gain_options`).
    law
        The law (:class:`nniquad.laws.base.ControlLaw`).
    defaults
        A gain block of the law whose values fill the gains not given (``None``: all its gains must be given).

    Raises
    ------
    NniquadError
        A gain of another law, a missing gain, or a gain that is not a finite positive number.
    """
    names = law.gain_names
    others = [n for n in _gain_fields() if n not in names and getattr(args, n, None) is not None]
    if others:
        raise NniquadError(f"{' '.join(gain_option(n) for n in others)} are not gains of the {law.name} law "
                           "(--controller)")
    given = {n: finite_positive(n, getattr(args, n)) for n in names if getattr(args, n, None) is not None}
    if not given:
        return None
    if defaults is not None:  # its fields as they are (an optional gain left unset stays unset)
        given = {**{f.name: getattr(defaults, f.name) for f in fields(defaults)}, **given}
    required = [f.name for f in fields(law.gains_type) if f.default is MISSING]
    missing = [n for n in required if n not in given]
    if missing:
        raise NniquadError(f"give all of {', '.join(gain_option(n) for n in required)} for given {law.name} gains")
    return law.gains(given)


def step_hints(**extra: str) -> dict[str, str]:
    """What to change for a pole too fast for the RK4 step, in this command's option names: each law's controller
    pole (its gains' options, or ``--dt``) and ``extra`` (``attitude="--attitude-wn or --dt"``, ...).

    Parameters
    ----------
    **extra
        Pole name -> what to change (underscores in the pole name stand for spaces: ``motor_lag``).
    """
    hints = {}
    for law in LAWS.values():
        ctrl = [gain_option(n) for n in law.gain_names if n not in ("kp", "kpy")]
        hints[law.pole_label] = f"{', '.join(ctrl)} or --dt" if ctrl else "--dt"
    hints.update({k.replace("_", " "): v for k, v in extra.items()})
    return hints


def add_delay_option(parser: Any, default: int | None, what: str) -> None:
    """Add ``--delay-samples N``: the measurement delay in control periods, with what it means in milliseconds.

    Parameters
    ----------
    parser
        The parser or argument group.
    default
        The default [samples] (``None``: the command's own, said in ``what``).
    what
        The end of the help text (what the delay applies to, and the default).
    """
    ms = 1000.0 / CONTROL_RATE_HZ
    parser.add_argument("--delay-samples", type=int, default=default, metavar="N",
                        help=f"measurement delay in samples: the position reaches the law N control periods late "
                             f"(N/rate s: {ms:g} ms per sample at {CONTROL_RATE_HZ:g} Hz, so 2 = {2 * ms:g} ms); "
                             + what)


def delay_samples(args: argparse.Namespace) -> int | None:
    """``--delay-samples`` checked (a whole number >= 0; one line otherwise), ``None`` when not given."""
    value = getattr(args, "delay_samples", None)
    if value is not None and value < 0:
        raise NniquadError(f"--delay-samples must be a whole number of samples >= 0, got {value}")
    return value
