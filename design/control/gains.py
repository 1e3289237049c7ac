"""Typed gain blocks: the paper's NNI controller, the PD comparison laws and the inner loops.

Each block validates its numbers on construction (a one-line error naming the
gain).  The simulator reads the controller law from the block's type, and its
parameter-vector layout from the blocks' fields.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

from nniquad.errors import GainError, SimulationError
from nniquad.validate import finite_number

__all__ = ["positive_gain", "Gains", "PAPER_GAINS", "PDGains", "InnerLoopGains", "DEFAULT_INNER_LOOP_GAINS"]


def positive_gain(name: str, value: float) -> float:
    """``value`` as a finite positive float, else :class:`GainError` naming ``name``."""
    return finite_number(name, value, error=GainError, positive=True)


@dataclass(frozen=True)
class Gains:
    """A gain set of the paper's controller.

    Parameters
    ----------
    kp
        Inner-loop proportional gain of the x axis, :math:`k_p^x` (1/s^2).
    Gamma
        Integral resonant controller gain Γ.
    delta
        Integral resonant controller parameter δ (DC gain of C(s) is 1/δ).
    kpy
        Inner-loop gain of the y axis; ``None`` means equal to ``kp``.

    Raises
    ------
    GainError
        If a gain is not a finite positive number (one-line message naming it).
    """

    kp: float
    Gamma: float
    delta: float
    kpy: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "kp", positive_gain("kp", self.kp))
        object.__setattr__(self, "Gamma", positive_gain("Gamma", self.Gamma))
        object.__setattr__(self, "delta", positive_gain("delta", self.delta))
        if self.kpy is not None:
            object.__setattr__(self, "kpy", positive_gain("kpy", self.kpy))

    @property
    def kpx(self) -> float:
        """Inner-loop gain of the x axis."""
        return self.kp

    @property
    def kp_y(self) -> float:
        """Inner-loop gain of the y axis (``kp`` when ``kpy`` is ``None``)."""
        return self.kp if self.kpy is None else self.kpy

    def axes(self) -> tuple[float, float]:
        """``(kpx, kpy)``."""
        return self.kp, self.kp_y

    def as_dict(self) -> dict[str, float]:
        """Plain dictionary (``kpy`` resolved)."""
        return {"kp": self.kp, "kpy": self.kp_y, "Gamma": self.Gamma, "delta": self.delta}


#: The paper's gains (Table "Simulation Parameters"): kp^x = kp^y = 5, Γ = 160, δ = 0.6.
PAPER_GAINS = Gains(kp=5.0, Gamma=160.0, delta=0.6)


@dataclass(frozen=True)
class PDGains:
    """Gains of the PD comparison controllers ``a_h = -k_p ξ_m - k_d v`` (both axes alike).

    Attributes
    ----------
    kp
        Position gain [1/s²] (> 0).
    kd
        Derivative gain [1/s] (> 0).
    tau_f
        Time constant of the dirty-derivative filter [s] (``pd_filtered``; > 0
        there, ignored by ``pd_velocity``; default 0.02).
    """

    kp: float
    kd: float
    tau_f: float = 0.02

    def __post_init__(self) -> None:
        for name in ("kp", "kd", "tau_f"):
            object.__setattr__(self, name, positive_gain(name, getattr(self, name)))

    def as_dict(self) -> dict[str, float]:
        return {"kp": self.kp, "kd": self.kd, "tau_f": self.tau_f}


@dataclass(frozen=True)
class InnerLoopGains:
    """Gains of the loops the paper leaves unspecified (see the module docstring).

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

    attitude_wn_rad_s: float = 25.0
    attitude_zeta: float = 0.8
    yaw_wn_rad_s: float = 8.0
    yaw_zeta: float = 0.8
    altitude_wn_rad_s: float = 3.0
    attitude_gain_scale: float = 1.0
    attitude_accel_limit_rad_s2: float = 1e6

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
        return asdict(self)


DEFAULT_INNER_LOOP_GAINS = InnerLoopGains()
