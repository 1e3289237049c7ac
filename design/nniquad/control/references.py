"""Horizontal references ``ξ_h^d(t)``: what the position loop follows, with its own derivatives.

The paper's block diagram has a reference ``ξ_h^d``; a velocity-free law needs
only the position error ``ξ_m - ξ_d`` (:mod:`nniquad.sim.models`), and the
optional acceleration feedforward reads ``ẍ_d`` from the reference itself, so
nothing is measured to follow it.  Every reference answers :meth:`Reference.sample`
with position [m], velocity [m/s] and acceleration [m/s²] (north, east) at any
array of times, and :meth:`Reference.jerk` [m/s³].

Types
-----
:class:`SetpointSteps`
    Piecewise-constant setpoints: ``points[i]`` from ``times[i]`` on (a step has
    no finite derivative: velocity and acceleration are zero, no feedforward).
:class:`MinimumJerk`
    Rest-to-rest minimum-jerk legs between consecutive waypoints: on a leg of
    duration ``T`` from ``p0`` to ``p1``, ``ξ_d = p0 + (p1 - p0) s(τ)``, ``τ = (t - t0)/T``,
    ``s = 10τ³ - 15τ⁴ + 6τ⁵``, so velocity and acceleration are zero at every
    waypoint (the vehicle stops there); a leg of zero length is a hold.
:class:`Circle`
    ``ξ_d = R (cos ωt, sin ωt)``, ``ω = 2π/T``: centred on the origin, starting at ``(R, 0)``.
:class:`FigureEight`
    ``ξ_d = (A_x sin ωt, A_y sin 2ωt)``, ``ω = 2π/T``: through the origin, north extent
    ``±A_x``, east extent ``±A_y`` (``A_x``, ``A_y`` are amplitudes).
:class:`TimeShifted`
    Another reference from a later time on, ``ξ_d(t + t_0)`` (a run that takes over mid-way).

Before its first time a reference holds its start, after its last time its end
(the periodic ones run on).  Files and specs (``circle:R,T``, ``figure8:AX,AY,T``,
a CSV or TOML waypoint file) are read by :mod:`nniquad.control.reference_files`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from nniquad.errors import InputError
from nniquad.validate import finite_number

__all__ = ["Reference", "Schedule", "SetpointSteps", "MinimumJerk", "Circle", "FigureEight", "TimeShifted", "Samples"]

#: ``(position, velocity, acceleration)``, each ``(N, 2)`` [m, m/s, m/s²].
Samples = tuple[np.ndarray, np.ndarray, np.ndarray]


def _times(t: Any) -> np.ndarray:
    return np.atleast_1d(np.asarray(t, float))


class Reference:
    """A horizontal reference (module docstring); subclasses are frozen dataclasses (hashable options)."""

    #: How the reference was given (a spec or a file path), for records; ``""`` when built in Python.
    spec: str

    def sample(self, t: Any) -> Samples:
        """Position [m], velocity [m/s] and acceleration [m/s²] at the times ``t`` [s], each ``(N, 2)``.

        Parameters
        ----------
        t
            A time or an array of times [s].
        """
        raise NotImplementedError

    def jerk(self, t: Any) -> np.ndarray:
        """Jerk [m/s³] at the times ``t``, ``(N, 2)``.

        Parameters
        ----------
        t
            A time or an array of times [s].
        """
        raise NotImplementedError

    def position(self, t: Any) -> np.ndarray:
        """Position [m] at the times ``t``, ``(N, 2)``.

        Parameters
        ----------
        t
            A time or an array of times [s].
        """
        return self.sample(t)[0]

    @property
    def waypoints(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``(times (n,), points (n, 2))`` the reference stops at (arrival metrics), ``None`` for a trajectory."""
        return None

    @property
    def end_s(self) -> float:
        """Time the reference reaches its last point [s] (``inf`` for a periodic one)."""
        return math.inf

    def describe(self) -> str:
        """One line for printed summaries."""
        return self.spec or type(self).__name__

    def to_json(self) -> dict[str, Any]:
        """The record of the reference: its type, its spec and its numbers."""
        out: dict[str, Any] = {"type": type(self).__name__, "spec": self.spec}
        for name, value in vars(self).items():
            if name != "spec":
                out[name] = np.asarray(value).tolist() if isinstance(value, tuple) else value
        return out


def _check_schedule(times: Sequence[float], points: Sequence[Sequence[float]], what: str
                    ) -> tuple[tuple[float, ...], tuple[tuple[float, float], ...]]:
    """Times (strictly increasing, finite) and points ``(x, y)`` (finite), as tuples; else one-line InputError."""
    ts = tuple(finite_number(f"{what} time", v, error=InputError) for v in times)
    try:
        ps = tuple((finite_number(f"{what} x", p[0], error=InputError), finite_number(f"{what} y", p[1], error=InputError))
                   for p in points)
    except (TypeError, IndexError):
        raise InputError(f"{what}: every point must be a pair (x, y) in metres") from None
    if not ts or len(ts) != len(ps):
        raise InputError(f"{what}: {len(ts)} times for {len(ps)} points (give one time per point, at least one)")
    bad = [i for i in range(1, len(ts)) if ts[i] <= ts[i - 1]]
    if bad:
        raise InputError(f"{what}: times must increase, got {ts[bad[0] - 1]:g} s then {ts[bad[0]]:g} s")
    return ts, ps


@dataclass(frozen=True)
class Schedule(Reference):
    """A reference through waypoints at given times (what :class:`SetpointSteps` and :class:`MinimumJerk` share).

    Attributes
    ----------
    times
        Time [s] of each waypoint, increasing.
    points
        The waypoints ``(north, east)`` [m].
    spec
        How it was given.
    """

    times: tuple[float, ...]
    points: tuple[tuple[float, float], ...]
    spec: str = ""

    def __post_init__(self) -> None:
        ts, ps = _check_schedule(self.times, self.points, "waypoints")
        object.__setattr__(self, "times", ts)
        object.__setattr__(self, "points", ps)

    @property
    def waypoints(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self.times), np.asarray(self.points)

    @property
    def end_s(self) -> float:
        return self.times[-1]


@dataclass(frozen=True)
class SetpointSteps(Schedule):
    """Setpoint ``points[i]`` from ``times[i]`` on; ``points[0]`` before (module docstring)."""

    def sample(self, t: Any) -> Samples:
        t = _times(t)
        i = np.clip(np.searchsorted(np.asarray(self.times), t, side="right") - 1, 0, None)
        pos = np.asarray(self.points)[i]
        return pos, np.zeros_like(pos), np.zeros_like(pos)

    def jerk(self, t: Any) -> np.ndarray:
        return np.zeros((_times(t).size, 2))


@dataclass(frozen=True)
class MinimumJerk(Schedule):
    """Rest-to-rest minimum-jerk legs through ``points``, reached at ``times`` (module docstring)."""

    def _leg(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per time: the leg's start point, its displacement, its duration and ``τ`` clipped to [0, 1]."""
        T, P = np.asarray(self.times), np.asarray(self.points)
        if T.size == 1:
            n = t.size
            return np.repeat(P, n, axis=0), np.zeros((n, 2)), np.ones(n), np.ones(n)
        i = np.clip(np.searchsorted(T, t, side="right") - 1, 0, T.size - 2)
        dur = T[i + 1] - T[i]
        tau = np.clip((t - T[i]) / dur, 0.0, 1.0)
        return P[i], P[i + 1] - P[i], dur, tau

    def sample(self, t: Any) -> Samples:
        p0, d, T, tau = self._leg(_times(t))
        s = tau**3 * (10 - 15 * tau + 6 * tau**2)
        ds = 30 * tau**2 * (1 - tau) ** 2 / T
        dds = 60 * tau * (1 - tau) * (1 - 2 * tau) / T**2
        return p0 + d * s[:, None], d * ds[:, None], d * dds[:, None]

    def jerk(self, t: Any) -> np.ndarray:
        t = _times(t)
        _, d, T, tau = self._leg(t)
        inside = (t > self.times[0]) & (t < self.times[-1])
        return d * (np.where(inside, 60 * (1 - 6 * tau + 6 * tau**2), 0.0) / T**3)[:, None]


def _positive(name: str, value: Any) -> float:
    return finite_number(name, value, error=InputError, positive=True)


@dataclass(frozen=True)
class Circle(Reference):
    """``ξ_d = R (cos ωt, sin ωt)``, ``ω = 2π/T`` (module docstring).

    Attributes
    ----------
    radius_m
        ``R`` [m].
    period_s
        ``T`` [s].
    spec
        How it was given.
    """

    radius_m: float
    period_s: float
    spec: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius_m", _positive("circle radius", self.radius_m))
        object.__setattr__(self, "period_s", _positive("circle period", self.period_s))

    def sample(self, t: Any) -> Samples:
        w = 2 * math.pi / self.period_s
        c, s = np.cos(w * _times(t)), np.sin(w * _times(t))
        R = self.radius_m
        return (np.stack([R * c, R * s], 1), np.stack([-R * w * s, R * w * c], 1),
                np.stack([-R * w**2 * c, -R * w**2 * s], 1))

    def jerk(self, t: Any) -> np.ndarray:
        w = 2 * math.pi / self.period_s
        return -w**2 * self.sample(t)[1]


@dataclass(frozen=True)
class FigureEight(Reference):
    """``ξ_d = (A_x sin ωt, A_y sin 2ωt)``, ``ω = 2π/T`` (module docstring).

    Attributes
    ----------
    ax_m, ay_m
        Amplitudes north and east [m].
    period_s
        ``T`` [s]: one whole figure.
    spec
        How it was given.
    """

    ax_m: float
    ay_m: float
    period_s: float
    spec: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "ax_m", _positive("figure-eight north amplitude", self.ax_m))
        object.__setattr__(self, "ay_m", _positive("figure-eight east amplitude", self.ay_m))
        object.__setattr__(self, "period_s", _positive("figure-eight period", self.period_s))

    def _harmonics(self, t: Any, order: int) -> np.ndarray:
        """The ``order``-th derivative of ``(A_x sin ωt, A_y sin 2ωt)``: ``A (kω)^n sin(kωt + nπ/2)``."""
        w = 2 * math.pi / self.period_s
        t = _times(t)
        cols = [A * (k * w) ** order * np.sin(k * w * t + order * math.pi / 2)
                for A, k in ((self.ax_m, 1), (self.ay_m, 2))]
        return np.stack(cols, 1)

    def sample(self, t: Any) -> Samples:
        return self._harmonics(t, 0), self._harmonics(t, 1), self._harmonics(t, 2)

    def jerk(self, t: Any) -> np.ndarray:
        return self._harmonics(t, 3)


@dataclass(frozen=True)
class TimeShifted(Reference):
    """``reference`` from ``offset_s`` on: ``ξ_d(t) = reference(t + offset_s)``.

    Attributes
    ----------
    reference
        The reference shifted.
    offset_s
        The shift [s].
    spec
        How it was given.
    """

    reference: Reference
    offset_s: float
    spec: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.reference, Reference):
            raise InputError(f"a time shift needs a Reference, got {type(self.reference).__name__}")
        object.__setattr__(self, "offset_s", finite_number("time shift", self.offset_s, error=InputError))

    def sample(self, t: Any) -> Samples:
        return self.reference.sample(_times(t) + self.offset_s)

    def jerk(self, t: Any) -> np.ndarray:
        return self.reference.jerk(_times(t) + self.offset_s)

    @property
    def waypoints(self) -> tuple[np.ndarray, np.ndarray] | None:
        wp = self.reference.waypoints
        return None if wp is None else (wp[0] - self.offset_s, wp[1])

    @property
    def end_s(self) -> float:
        return self.reference.end_s - self.offset_s

    def to_json(self) -> dict[str, Any]:
        return {"type": "TimeShifted", "spec": self.spec, "offset_s": self.offset_s,
                "reference": self.reference.to_json()}
