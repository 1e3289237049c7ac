"""Tracking metrics of a run that follows a reference: one definition of each (``DESIGN.md``, "Tracking").

* **Tracking error** -- ``‖ξ_h(t) - ξ_d(t)‖`` at the output samples, the reference
  evaluated exactly at the sample times.  ``tracking_rms_m`` is its RMS over the
  stated window ``[t0, t1]`` (trapezoidal rule, as every time-weighted metric of
  :mod:`nniquad.sim.metrics`), ``tracking_max_m`` its maximum there.  The window
  is part of the record: a run that starts off the reference includes its
  transient unless the window leaves it out.
* **Arrival at a waypoint** -- for each waypoint ``p_i`` reached by a leg of
  length ``L_i > 0`` from the previous one (a repeated waypoint is a hold, not a
  leg): the first output sample at or after the leg's start from which the
  position stays within the band ``‖ξ_h - p_i‖ ≤ band_fraction · L_i`` (2 %,
  :data:`nniquad.config.BAND_FRACTION`) until the reference leaves ``p_i`` (the
  start of the next leg; the end of the run for the last waypoint, or if the run
  ends first).  ``None``: not reached.  Its delay is the arrival time minus the
  time the reference itself arrives.
* **Demanded tilt** -- ``atan(max ‖ξ̈_d‖ / g)`` over the window: the tilt the
  reference alone needs (the feedforward's share of the limit,
  :mod:`nniquad.laws.base`, "Reference and feedforward"), against the tilt limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from nniquad.config import BAND_FRACTION
from nniquad.control.references import Reference
from nniquad.errors import SimulationError

__all__ = ["Arrival", "TrackingMetrics", "tracking_metrics", "arrivals"]


@dataclass(frozen=True)
class Arrival:
    """The arrival at one waypoint (module docstring).

    Attributes
    ----------
    index
        The waypoint's index in the reference's list.
    point
        The waypoint (north, east) [m].
    scheduled_s
        When the reference arrives [s].
    band_m
        The band's radius, ``band_fraction`` times the leg's length [m].
    arrival_s
        When the vehicle arrives [s]; ``None``: not reached.
    """

    index: int
    point: tuple[float, float]
    scheduled_s: float
    band_m: float
    arrival_s: float | None

    @property
    def delay_s(self) -> float | None:
        """Arrival minus the reference's arrival [s]; ``None`` when not reached."""
        return None if self.arrival_s is None else self.arrival_s - self.scheduled_s

    def to_json(self) -> dict[str, Any]:
        return {"index": self.index, "point_m": list(self.point), "scheduled_s": self.scheduled_s,
                "band_m": self.band_m, "arrival_s": self.arrival_s, "delay_s": self.delay_s}


@dataclass(frozen=True)
class TrackingMetrics:
    """The tracking numbers of one run (module docstring).

    Attributes
    ----------
    window_s
        ``(t0, t1)`` [s], the window of the RMS and the maximum.
    tracking_rms_m, tracking_max_m
        RMS and maximum of ``‖ξ_h - ξ_d‖`` over the window [m].
    demanded_tilt_deg
        ``atan(max ‖ξ̈_d‖ / g)`` over the window [deg].
    tilt_limit_deg
        The run's tilt limit [deg].
    arrivals
        One :class:`Arrival` per waypoint reached by a leg (empty for a trajectory).
    """

    window_s: tuple[float, float]
    tracking_rms_m: float
    tracking_max_m: float
    demanded_tilt_deg: float
    tilt_limit_deg: float
    arrivals: tuple[Arrival, ...] = ()

    @property
    def all_arrived(self) -> bool:
        """Whether every waypoint was reached within its band."""
        return all(a.arrival_s is not None for a in self.arrivals)

    def to_json(self) -> dict[str, Any]:
        """The JSON metrics' keys: ``tracking_rms_m``, ``tracking_max_m``, the window, the tilt, the arrivals."""
        return {"tracking_rms_m": self.tracking_rms_m, "tracking_max_m": self.tracking_max_m,
                "tracking_window_s": list(self.window_s), "demanded_tilt_deg": self.demanded_tilt_deg,
                "tilt_limit_deg": self.tilt_limit_deg, "arrivals": [a.to_json() for a in self.arrivals]}

    def lines(self) -> list[str]:
        """Printed summary, with units."""
        t0, t1 = self.window_s
        out = [f"tracking error over [{t0:g}, {t1:g}] s: RMS {self.tracking_rms_m:.4g} m, max {self.tracking_max_m:.4g} m",
               f"tilt the reference demands: {self.demanded_tilt_deg:.3g} deg (limit {self.tilt_limit_deg:g} deg)"]
        for a in self.arrivals:
            when = "not reached" if a.arrival_s is None else f"at {a.arrival_s:.3f} s (delay {a.delay_s:+.3f} s)"
            out.append(f"waypoint {a.index} ({a.point[0]:g}, {a.point[1]:g}) m, band {a.band_m:.3g} m: {when}")
        return out


def arrivals(t: np.ndarray, xy: np.ndarray, reference: Reference,
             band_fraction: float = BAND_FRACTION) -> tuple[Arrival, ...]:
    """The arrival at every waypoint of ``reference`` reached by a leg (module docstring).

    Parameters
    ----------
    t
        Sample times [s], ``(N,)``, increasing.
    xy
        Positions [m], ``(N, 2)``.
    reference
        The reference; one without waypoints has none.
    band_fraction
        The band as a fraction of the leg's length.
    """
    wp = reference.waypoints
    if wp is None:
        return ()
    times, points = wp
    out = []
    last = 0  # the waypoint the current leg starts from (its last repeat: the leg starts when the hold ends)
    for i in range(1, len(points)):
        length = float(np.hypot(*(points[i] - points[last])))
        if length == 0.0:
            last = i
            continue
        # the reference leaves p_i when the leg after its last repeat starts
        j = i
        while j + 1 < len(points) and np.all(points[j + 1] == points[i]):
            j += 1
        leave = times[j] if j + 1 < len(points) else math.inf
        band = band_fraction * length
        span = (t >= times[last]) & (t <= leave)
        inside = np.hypot(*(xy - points[i]).T) <= band
        idx = np.flatnonzero(span)
        arrival = None
        if idx.size and inside[idx[-1]]:
            outside = idx[~inside[idx]]
            first = idx[0] if outside.size == 0 else outside[-1] + 1
            arrival = float(t[first])
        out.append(Arrival(i, (float(points[i][0]), float(points[i][1])), float(times[i]), band, arrival))
        last = i
    return tuple(out)


def tracking_metrics(t: np.ndarray, xy: np.ndarray, reference: Reference, *, g: float, tilt_limit_deg: float,
                     window_s: tuple[float, float] | None = None,
                     band_fraction: float = BAND_FRACTION) -> TrackingMetrics:
    """The tracking numbers of one run (module docstring).

    Parameters
    ----------
    t
        Sample times [s], ``(N,)``, increasing.
    xy
        Positions [m], ``(N, 2)``.
    reference
        The reference the run followed.
    g
        Gravity [m/s²] (the demanded tilt).
    tilt_limit_deg
        The run's tilt limit [deg].
    window_s
        ``(t0, t1)`` of the RMS and the maximum; default the whole run.
    band_fraction
        The arrival band as a fraction of each leg's length.

    Raises
    ------
    SimulationError
        A window that holds fewer than two samples.
    """
    t, xy = np.asarray(t, float), np.asarray(xy, float)
    t0, t1 = (float(t[0]), float(t[-1])) if window_s is None else (float(window_s[0]), float(window_s[1]))
    sel = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
    if np.count_nonzero(sel) < 2:
        raise SimulationError(f"tracking window [{t0:g}, {t1:g}] s holds fewer than two samples of the run")
    pos, _, acc = reference.sample(t[sel])
    err = np.hypot(*(xy[sel] - pos).T)
    ts = t[sel]
    rms = math.sqrt(float(np.trapezoid(err**2, ts)) / (ts[-1] - ts[0]))
    demanded = math.degrees(math.atan(float(np.max(np.hypot(*acc.T))) / g))
    return TrackingMetrics((t0, t1), rms, float(err.max()), demanded, float(tilt_limit_deg),
                           arrivals(t, xy, reference, band_fraction))
