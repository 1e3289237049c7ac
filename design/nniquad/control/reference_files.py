"""References from a spec or a file: ``circle:R,T``, ``figure8:AX,AY,T``, a CSV or a TOML waypoint list.

Specs (metres, seconds)
    ``circle:R,T`` is :class:`~nniquad.control.references.Circle` (radius ``R``, period ``T``);
    ``figure8:AX,AY,T`` is :class:`~nniquad.control.references.FigureEight` (amplitudes north
    and east, period).
CSV (``.csv``)
    The header ``t,x,y`` then one waypoint per line: time [s], north [m], east [m];
    rest-to-rest minimum-jerk legs between them
    (:class:`~nniquad.control.references.MinimumJerk`).  A waypoint repeated at a later
    time is a hold.
TOML (``.toml``)
    ``points = [[x, y], ...]`` [m] and either ``times = [...]`` [s] or
    ``cruise_speed_m_s`` (each leg lasts its length over that speed: the leg's mean
    speed; the minimum-jerk peak is 15/8 of it), optionally ``hold_s`` (a stop at
    every waypoint after the first, default 0) and ``start_s`` (default 0), and
    ``kind = "min_jerk"`` (default) or ``"steps"``
    (:class:`~nniquad.control.references.SetpointSteps`: the setpoint jumps at each time).

Every problem is one line of :class:`nniquad.errors.InputError`.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Any

from nniquad.control.references import Circle, FigureEight, MinimumJerk, Reference, SetpointSteps
from nniquad.errors import InputError
from nniquad.io import load_data_file, read_text_file
from nniquad.validate import finite_number

__all__ = ["parse_reference", "read_waypoints_csv", "read_waypoints_toml", "SPEC_FORMS"]

#: The spec forms, as ``--help`` lists them.
SPEC_FORMS = "a waypoint file (.csv with header t,x,y, or .toml), circle:R,T or figure8:AX,AY,T (metres, seconds)"

_SHAPES = {"circle": (Circle, ("radius R", "period T")),
           "figure8": (FigureEight, ("north amplitude AX", "east amplitude AY", "period T"))}


def parse_reference(spec: str) -> Reference:
    """The reference a spec names (module docstring).

    Parameters
    ----------
    spec
        ``circle:R,T``, ``figure8:AX,AY,T`` or a path to a ``.csv`` / ``.toml`` waypoint file.

    Raises
    ------
    InputError
        An unknown form, a wrong number of fields, a non-number, or a bad file (one line).
    """
    if not isinstance(spec, str) or not spec.strip():
        raise InputError(f"reference: expected {SPEC_FORMS}, got {spec!r}")
    head, sep, tail = spec.partition(":")
    if sep and head in _SHAPES:
        cls, names = _SHAPES[head]
        fields = tail.split(",")
        if len(fields) != len(names):
            raise InputError(f"reference {spec!r}: {head} takes {len(names)} numbers ({', '.join(names)}), "
                             f"got {len(fields)}")
        values = [finite_number(f"reference {spec!r}: {n}", f.strip(), error=InputError, positive=True)
                  for n, f in zip(names, fields)]
        return cls(*values, spec=spec)
    suffix = Path(spec).suffix.lower()
    if suffix == ".csv":
        return read_waypoints_csv(spec)
    if suffix == ".toml":
        return read_waypoints_toml(spec)
    raise InputError(f"reference {spec!r}: expected {SPEC_FORMS}")


def read_waypoints_csv(path: str) -> MinimumJerk:
    """Minimum-jerk legs through the waypoints of a CSV file with the header ``t,x,y``.

    Parameters
    ----------
    path
        The file.
    """
    text = read_text_file(path, what="reference file")
    rows = [r for r in csv.reader(io.StringIO(text)) if any(c.strip() for c in r)]
    if not rows or [c.strip() for c in rows[0]] != ["t", "x", "y"]:
        raise InputError(f"{path}: the first line must be the header t,x,y (time s, north m, east m)")
    times, points = [], []
    for n, row in enumerate(rows[1:], start=2):
        if len(row) != 3:
            raise InputError(f"{path}, line {n}: expected 3 fields t,x,y, got {len(row)}")
        t, x, y = (finite_number(f"{path}, line {n}: {k}", v.strip(), error=InputError) for k, v in zip("txy", row))
        times.append(t)
        points.append((x, y))
    if not points:
        raise InputError(f"{path}: no waypoint after the header")
    return MinimumJerk(tuple(times), tuple(points), spec=str(path))


def _schedule_from_speed(points: list[tuple[float, float]], speed: float, hold: float, start: float) -> list[float]:
    """Arrival times: each leg lasts its length over ``speed``, each waypoint after the first is held ``hold``."""
    times = [start]
    for a, b in zip(points, points[1:]):
        times.append(times[-1] + (hold if len(times) > 1 else 0.0) + math.dist(a, b) / speed)
    return times


def read_waypoints_toml(path: str) -> Reference:
    """The reference of a TOML waypoint file (module docstring).

    Parameters
    ----------
    path
        The file.
    """
    data: Any = load_data_file(path, what="reference file", error=InputError)
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a TOML table")
    known = {"points", "times", "cruise_speed_m_s", "hold_s", "start_s", "kind"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise InputError(f"{path}: unknown key {unknown[0]!r} (keys: {', '.join(sorted(known))})")
    raw = data.get("points")
    if not isinstance(raw, list) or not raw or not all(isinstance(p, list) and len(p) == 2 for p in raw):
        raise InputError(f"{path}: points must be a non-empty list of [x, y] pairs in metres")
    points = [(finite_number(f"{path}: point x", p[0], error=InputError),
               finite_number(f"{path}: point y", p[1], error=InputError)) for p in raw]
    kind = data.get("kind", "min_jerk")
    if kind not in ("min_jerk", "steps"):
        raise InputError(f"{path}: kind must be \"min_jerk\" or \"steps\", got {kind!r}")
    hold = finite_number(f"{path}: hold_s", data.get("hold_s", 0.0), error=InputError, nonneg=True)
    start = finite_number(f"{path}: start_s", data.get("start_s", 0.0), error=InputError)
    if ("times" in data) == ("cruise_speed_m_s" in data):
        raise InputError(f"{path}: give either times or cruise_speed_m_s (one of them)")
    if "times" in data:
        if not isinstance(data["times"], list):
            raise InputError(f"{path}: times must be a list of seconds")
        times = [start + finite_number(f"{path}: time", t, error=InputError) for t in data["times"]]
    else:
        speed = finite_number(f"{path}: cruise_speed_m_s", data["cruise_speed_m_s"], error=InputError, positive=True)
        times = _schedule_from_speed(points, speed, hold, start)
    if hold > 0 and "times" in data:
        raise InputError(f"{path}: hold_s goes with cruise_speed_m_s; with times, repeat a waypoint to hold it")
    if hold > 0:
        # a hold is the same waypoint again, hold_s before the next leg starts
        points = [p for i, p in enumerate(points) for _ in range(1 if i in (0, len(points) - 1) else 2)]
        times = [times[0]] + [x for i, t in enumerate(times[1:-1], start=1) for x in (t, t + hold)] + times[-1:] \
            if len(times) > 1 else times
    cls = SetpointSteps if kind == "steps" else MinimumJerk
    return cls(tuple(times), tuple(points), spec=str(path))
