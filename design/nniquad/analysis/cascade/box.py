"""The parameter box of the cascade certificate: intervals of factors on the nominal vehicle, and their coordinates.

A point is six factors ``θ = (f_m, f_Jx, f_Jy, f_Jz, f_a, f_τ)`` (:data:`POINT_NAMES`): the true mass, the
three inertias (independent inside ``inertia_factor``), the attitude-torque factor and the motor time constant.
A subsystem's coordinates are the log factors of the coordinates it depends on, normalised to ``[-1, 1]`` on
the box (:func:`box_coordinates`, :func:`normalised_coordinates`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, fields
from typing import Any, Mapping, Sequence

import numpy as np

from nniquad.errors import CascadeError
from nniquad.model.vehicle import Vehicle
from nniquad.scenarios.draws import DEFAULT_RANGES

__all__ = ["BOX_KEYS", "POINT_NAMES", "ParameterBox", "box_coordinates", "tilt_accel_limit"]

#: Keys of a box in JSON, in order.
BOX_KEYS: tuple[str, ...] = ("mass_factor", "inertia_factor", "attitude_gain_factor", "tau_motor_factor")
#: Coordinates of a parameter point (the inertia factor is three independent coordinates).
POINT_NAMES: tuple[str, ...] = ("mass", "Jx", "Jy", "Jz", "attitude_gain", "tau_motor")
_POINT_BOX = (0, 1, 1, 1, 2, 3)  # which box interval each point coordinate takes


# =============================================================================== the box


def _interval(name: str, value: Any) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise CascadeError(f"box {name} must be a pair [low, high] of factors, got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo <= hi):
        raise CascadeError(f"box {name} must be finite factors with 0 < low <= high, got [{lo:g}, {hi:g}]")
    return lo, hi


@dataclass(frozen=True)
class ParameterBox:
    """Intervals of factors on the nominal vehicle (module docstring).

    Attributes
    ----------
    mass_factor
        True mass / nominal mass.
    inertia_factor
        True inertia / nominal, **each of Jx, Jy, Jz independently** in this interval.
    attitude_gain_factor
        Factor on the attitude-loop torques (``attitude_gain_scale``).
    tau_motor_factor
        Motor time constant / nominal.
    """

    mass_factor: tuple[float, float] = (1.0, 1.0)
    inertia_factor: tuple[float, float] = (1.0, 1.0)
    attitude_gain_factor: tuple[float, float] = (1.0, 1.0)
    tau_motor_factor: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, _interval(f.name, getattr(self, f.name)))

    @classmethod
    def monte_carlo_default(cls) -> "ParameterBox":
        """The Monte Carlo default ranges (:data:`nniquad.scenarios.draws.DEFAULT_RANGES`)."""

        return cls(**{k: getattr(DEFAULT_RANGES, k) for k in BOX_KEYS})

    def to_json(self) -> dict[str, list[float]]:
        return {k: list(getattr(self, k)) for k in BOX_KEYS}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> "ParameterBox":
        """Read a box; exactly the keys :data:`BOX_KEYS`."""
        if not isinstance(data, Mapping) or set(data) != set(BOX_KEYS):
            got = sorted(data) if isinstance(data, Mapping) else type(data).__name__
            raise CascadeError(f"a parameter box has exactly the keys {', '.join(BOX_KEYS)}; got {got}")
        return cls(**{k: data[k] for k in BOX_KEYS})

    def scaled(self, s: float) -> "ParameterBox":
        """The box scaled by ``s`` about the nominal point **in log space**: ``[lo^s, hi^s]``.

        Log space keeps every factor positive for any ``s >= 0`` and treats a
        factor and its inverse alike (``tau_motor_factor`` 0.5-2 is symmetric
        there); ``s = 0`` is the nominal point, ``s = 1`` this box.
        """
        if not (isinstance(s, (int, float)) and math.isfinite(s) and s >= 0):
            raise CascadeError(f"box scale must be a finite number >= 0, got {s!r}")
        return ParameterBox(**{k: (getattr(self, k)[0] ** s, getattr(self, k)[1] ** s) for k in BOX_KEYS})

    def contains(self, other: "ParameterBox", rtol: float = 1e-12) -> bool:
        """Whether every interval of ``other`` lies inside this box's."""
        return all(getattr(self, k)[0] <= getattr(other, k)[0] * (1 + rtol)
                   and getattr(other, k)[1] <= getattr(self, k)[1] * (1 + rtol) for k in BOX_KEYS)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper factors of the six point coordinates (:data:`POINT_NAMES`)."""
        iv = [getattr(self, k) for k in BOX_KEYS]
        return (np.array([iv[j][0] for j in _POINT_BOX]), np.array([iv[j][1] for j in _POINT_BOX]))

    def vertices(self) -> np.ndarray:
        """The distinct vertices ``(n_v, 6)`` (a degenerate interval gives one value)."""
        lo, hi = self.bounds()
        axes = [sorted({a, b}) for a, b in zip(lo, hi)]
        return np.array(list(itertools.product(*axes)), float)

    def grid(self, n: int) -> np.ndarray:
        """A tensor grid of ``n`` points per coordinate (ends included), ``(≤ n^6, 6)``; log-spaced."""
        lo, hi = self.bounds()
        axes = [np.unique(np.geomspace(a, b, n)) if b > a else np.array([a]) for a, b in zip(lo, hi)]
        return np.array(list(itertools.product(*axes)), float)


def box_coordinates(box: ParameterBox, points: np.ndarray) -> np.ndarray:
    """Normalised coordinates ``θ ∈ [-1, 1]`` (log factor, centred) of the non-degenerate box directions."""
    lo, hi = box.bounds()
    keep = hi > lo
    llo, lhi = np.log(lo[keep]), np.log(hi[keep])
    return (2.0 * np.log(np.atleast_2d(points)[:, keep]) - (llo + lhi)) / (lhi - llo)


def normalised_coordinates(box: ParameterBox, points: np.ndarray, dims: Sequence[int]) -> np.ndarray:
    lo, hi = box.bounds()
    d = list(dims)
    llo, lhi = np.log(lo[d]), np.log(hi[d])
    return (2.0 * np.log(np.atleast_2d(points)[:, d]) - (llo + lhi)) / (lhi - llo)


def grid_subset(box: ParameterBox, dims: Sequence[int], n: int) -> np.ndarray:
    """A grid of ``n`` points per coordinate over ``dims`` (log-spaced), the other coordinates nominal (1)."""
    lo, hi = box.bounds()
    axes = [np.geomspace(lo[j], hi[j], n) if j in dims else np.array([1.0]) for j in range(6)]
    return np.array(list(itertools.product(*axes)), float)


def tilt_accel_limit(vehicle: Vehicle, box: ParameterBox, tilt_limit_deg: float) -> float:
    """``u0 = (lowest mass factor) g tan(tilt)`` [m/s²]: the tilt limit as a bound on the horizontal command over the box."""
    return box.mass_factor[0] * vehicle.g * math.tan(math.radians(tilt_limit_deg))
