"""The gains of the loops the paper leaves unspecified: attitude, yaw hold and altitude (:mod:`.inner_loops`).

Every horizontal law runs inside these loops; they are not part of any law
(:mod:`nniquad.laws`), and the certificate states the ones its ``full``
performance was measured with.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Mapping

from nniquad.errors import SimulationError
from nniquad.laws.base import gain_field

__all__ = ["InnerLoopGains", "DEFAULT_INNER_LOOP_GAINS"]


@dataclass(frozen=True)
class InnerLoopGains:
    """Gains of the loops the paper leaves unspecified (:mod:`nniquad.control.inner_loops`).

    Attributes
    ----------
    attitude_wn_rad_s
        Natural frequency ω_a of roll and pitch [rad/s] (default 25).
    attitude_zeta
        Damping ratio ζ_a of roll and pitch (default 0.8).
    yaw_wn_rad_s
        Natural frequency ω_ψ of the yaw hold [rad/s] (default 8).
    yaw_zeta
        Damping ratio ζ_ψ of the yaw hold (default 0.8).
    altitude_wn_rad_s
        ω_z of the altitude PID, triple pole at ``-ω_z`` [rad/s] (default 3).
    attitude_gain_scale
        Factor on all attitude torques (1 = nominal); models an attitude-gain error.
    attitude_accel_limit_rad_s2
        Deceleration ``α`` of the square-root shaping of the roll/pitch error
        [rad/s²]; the default 1e6 leaves the linear PD unchanged.
    """

    attitude_wn_rad_s: float = gain_field("rad/s", "attitude natural frequency", default=25.0)
    attitude_zeta: float = gain_field("-", "attitude damping ratio", default=0.8)
    yaw_wn_rad_s: float = gain_field("rad/s", "yaw-hold natural frequency", default=8.0)
    yaw_zeta: float = gain_field("-", "yaw-hold damping ratio", default=0.8)
    altitude_wn_rad_s: float = gain_field("rad/s", "altitude PID triple-pole frequency", default=3.0)
    attitude_gain_scale: float = gain_field("-", "factor on the attitude torques (gain error)", default=1.0)
    attitude_accel_limit_rad_s2: float = gain_field("rad/s^2", "angular-acceleration limit of the attitude error shaping",
                                            default=1e6)

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise SimulationError(f"inner-loop gain {f.name} must be a number, got {value!r}") from None
            if not math.isfinite(v) or v <= 0.0:
                raise SimulationError(f"inner-loop gain {f.name} must be finite and positive, got {value!r}")
            object.__setattr__(self, f.name, v)

    def as_dict(self) -> dict[str, float]:
        """Plain dictionary of the gains."""
        return asdict(self)

    def values(self) -> dict[str, float]:
        """The numbers the simulator's parameter vector holds, in field order."""
        return asdict(self)

    @classmethod
    def from_values(cls, values: Mapping[str, float]) -> "InnerLoopGains":
        """Inverse of :meth:`values`.

        Parameters
        ----------
        values
            ``{field: value}``.
        """
        return cls(**{f.name: values[f.name] for f in fields(cls)})


DEFAULT_INNER_LOOP_GAINS = InnerLoopGains()
