"""The comparison PD law with the **true** horizontal velocity (a perfect velocity sensor).

``a_h = -k_p ξ_m - k_d ξ'`` on both axes: no controller state.  It is not
velocity-free, so no NI theorem covers it and it has no law class; the project
flies it beside the velocity-free laws as the yardstick they are measured
against.  In discrete time the velocity is sampled with the position and held
over the period (the simulator keeps the held velocity in the states
``zc_x, zc_y``).  Tuning coordinates: ``ln k_p`` and ``ζ = k_d/(2 sqrt k_p)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from nniquad.laws.base import ControlLaw, PlainGainBlock, TuningBox, gain_field, positive_gain
from nniquad.laws.registry import register
from nniquad.laws.search_ranges import KP_RANGE, PD_ZETA_RANGE

__all__ = ["PDGains", "PDVelocityLaw", "PD_VELOCITY"]


@dataclass(frozen=True)
class PDGains(PlainGainBlock):
    """PD comparison law with the **true** horizontal velocity, ``a_h = -k_p ξ_m - k_d ξ'`` (both axes alike).

    ``controller = "pd_velocity"`` (a perfect velocity sensor).

    Attributes
    ----------
    kp
        Position gain [1/s²] (> 0).
    kd
        Derivative gain [1/s] (> 0).
    """

    controller: ClassVar[str] = "pd_velocity"

    kp: float = gain_field("1/s^2", "PD position gain")
    kd: float = gain_field("1/s", "PD derivative gain")

    def time_scaled(self, factor: float) -> "PDGains":
        """The same loop ``factor`` times faster: ``k_p λ², k_d λ`` (``ξ_λ(t) = ξ(λ t)``).

        Parameters
        ----------
        factor
            Speed-up λ > 0.
        """
        lam = positive_gain("time-scale factor", factor)
        return PDGains(self.kp * lam**2, self.kd * lam)


class PDVelocityLaw(ControlLaw):
    """The PD law with the true velocity (module docstring)."""

    name: ClassVar[str] = "pd_velocity"
    title: ClassVar[str] = "PD with the true velocity (a perfect velocity sensor): the yardstick, not velocity-free"
    gains_type: ClassVar[type] = PDGains
    state_names: ClassVar[tuple[str, ...]] = ()
    state_units: ClassVar[tuple[str, ...]] = ()
    measures_velocity: ClassVar[bool] = True
    time_scaling: ClassVar[Mapping[str, int]] = {"kp": 2, "kd": 1}

    @property
    def sim_state_names(self) -> tuple[str, ...]:
        """The simulator's held velocity of the discrete variant, ``zc_x, zc_y`` (zero otherwise)."""
        return ("zc_x", "zc_y")

    def realisation(self, p: Mapping[str, Any], axis: int = 0) -> tuple[list, list, list, list]:
        return [], [], [[]], [[-p["kp"], -p["kd"]]]

    def sim_rates(self, p: Mapping[str, Any], meas: Sequence[Any], vel: Sequence[Any], xc: Sequence[Any],
                  discrete: Any, lib: Any) -> tuple[list, list]:
        # discrete variant: the velocity sampled with the position (held in zc by sim_sample)
        v = [lib.if_else(discrete, xc[a], vel[a]) for a in (0, 1)]
        return [-p["kp"] * meas[a] - p["kd"] * v[a] for a in (0, 1)], [0.0, 0.0]

    def sim_sample(self, p: Mapping[str, Any], xc: Sequence[Any], held: Sequence[Any], vel: Sequence[Any],
                   T: Any, sample: Any, advance: Any, lib: Any) -> list:
        # every sample (the first too) latches the true velocity with the position
        return [lib.if_else(sample, vel[a], xc[a]) for a in (0, 1)]

    def sim_start_state(self, gains: PDGains, m_hat: float, xi0: Sequence[float]) -> np.ndarray:
        return np.zeros(2)

    def static_stiffness(self, gains: PDGains, m_hat: float) -> tuple[float, float]:
        return float(m_hat) * gains.kp, float(m_hat) * gains.kp

    # ------------------------------------------------------------------ tuning
    def coordinates(self, law_class: str | None) -> tuple[str, ...]:
        return ("ln k_p", "zeta = k_d/(2 sqrt k_p)")

    def box(self, law_class: str | None, limits: TuningBox) -> tuple[list[float], list[float]]:
        return [math.log(KP_RANGE[0]), PD_ZETA_RANGE[0]], [math.log(limits.kp_max), PD_ZETA_RANGE[1]]

    def decode(self, q: Sequence[float], m: float, gamma_max: float, law_class: str | None) -> PDGains:
        kp = math.exp(q[0])
        return PDGains(kp=kp, kd=2.0 * float(q[1]) * math.sqrt(kp))

    def encode(self, gains: Any, m: float, gamma_max: float, law_class: str | None) -> list[float]:
        if not isinstance(gains, PDGains):
            raise ValueError(f"{type(gains).__name__} is not a gain block of the {self.name!r} law")
        return [math.log(gains.kp), gains.kd / (2.0 * math.sqrt(gains.kp))]


#: The registered PD law with the true velocity.
PD_VELOCITY = register(PDVelocityLaw())
