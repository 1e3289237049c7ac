"""The reference options of the commands that simulate: ``--reference SPEC``, ``--feedforward``,
``--feedforward-lead``, ``--start-at-rest`` and ``--tracking-window``."""

from __future__ import annotations

import argparse
from typing import Any

from nniquad.errors import SimulationError

__all__ = ["add_reference_options", "reference_settings", "tracking_window"]


def add_reference_options(parser: argparse.ArgumentParser | Any, *, single_run: bool = True) -> None:
    """Add the reference options to a parser or an argument group.

    Parameters
    ----------
    parser
        The parser or group.
    single_run
        Also ``--start-at-rest`` and ``--tracking-window`` (a command that runs one run).
    """
    # the spec forms are listed by nniquad.control.reference_files.SPEC_FORMS; spelled here so that --help
    # imports no numpy (the cold start of `nniquad --help`)
    parser.add_argument("--reference", metavar="SPEC", default=None,
                        help="follow a reference: a waypoint file (.csv with header t,x,y, or .toml), circle:R,T or "
                             "figure8:AX,AY,T (metres, seconds); a run starts on it with its velocity"
                             + (" unless --start-at-rest" if single_run else ""))
    parser.add_argument("--feedforward", action="store_true",
                        help="add the reference's acceleration to the command before the tilt limit (nothing "
                             "measured; it uses tilt authority: see docs/follow.md)")
    parser.add_argument("--feedforward-lead", type=float, default=0.0, metavar="S",
                        help="with --feedforward: read the reference's acceleration S seconds ahead, to cancel the "
                             "inner loop's lag (about 2 zeta_a/omega_a plus half a sample period; default 0)")
    if not single_run:
        return
    parser.add_argument("--start-at-rest", action="store_true",
                        help="with --reference: start at --xi0 at rest instead of on the reference")
    parser.add_argument("--tracking-window", type=float, nargs=2, default=None, metavar=("T0", "T1"),
                        help="with --reference: the window of the tracking RMS and maximum in s (default the whole "
                             "run)")


def reference_settings(args: argparse.Namespace) -> dict[str, Any]:
    """The :class:`~nniquad.sim.SimOptions` fields the reference options set (empty without ``--reference``).

    Parameters
    ----------
    args
        The parsed options.

    Raises
    ------
    SimulationError
        ``--feedforward``, ``--start-at-rest`` or ``--tracking-window`` without ``--reference``, or
        ``--feedforward-lead`` without ``--feedforward``.
    InputError
        A bad spec or file (:func:`nniquad.control.reference_files.parse_reference`).
    """
    if args.reference is None:
        for flag, given in (("--feedforward", args.feedforward),
                            ("--start-at-rest", getattr(args, "start_at_rest", False)),
                            ("--tracking-window", getattr(args, "tracking_window", None) is not None)):
            if given:
                raise SimulationError(f"{flag} needs --reference")
        if args.feedforward_lead:
            raise SimulationError("--feedforward-lead needs --reference and --feedforward")
        return {}
    # lazily: `nniquad --help` loads every command module, and its cold start stays under 0.5 s
    from nniquad.control.reference_files import parse_reference

    ref = parse_reference(args.reference)
    if args.feedforward_lead and not args.feedforward:
        raise SimulationError("--feedforward-lead needs --feedforward")
    out: dict[str, Any] = {"reference": ref, "feedforward": bool(args.feedforward),
                           "feedforward_lead_s": args.feedforward_lead}
    if not getattr(args, "start_at_rest", False):
        pos, vel, _ = ref.sample(0.0)
        out["xi0"], out["v0"] = tuple(map(float, pos[0])), tuple(map(float, vel[0]))
    return out


def tracking_window(args: argparse.Namespace) -> tuple[float, float] | None:
    """``--tracking-window`` as a pair, ``None`` when not given.

    Parameters
    ----------
    args
        The parsed options.
    """
    window = getattr(args, "tracking_window", None)
    return None if window is None else (float(window[0]), float(window[1]))
