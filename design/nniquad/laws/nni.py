"""The paper's law: a proportional inner loop and the integral resonant controller ``C(s) = Γ/(s + Γδ)``.

Per axis (Ghallab & Petersen, eqs. ``compact_horizontal``, ``SNI_controller``,
``controller_state_space``), with the controller's nominal mass ``m̂``:

.. math:: a_h = -k_p ξ + z/\\hat m, \\qquad \\dot z = -Γδ z + Γ ξ,

the controller output ``z`` [N] in **positive** feedback.  ``C(0) = 1/δ``, so the
DC loop gain (the sector constant) is ``γ = 1/(m k_p δ)`` and the paper's sector
bound ``δ >= 1/(γ_max m k_p)`` is ``γ <= γ_max``; for this loop the condition is
also necessary (Routh: stable iff ``m k_p δ > 1``).  The two axes may have two
inner gains (``kp``, ``kpy``).

The controller starts at ``z = 0`` (the paper's initial condition; ``SimOptions.zc0``
adds to it).  The exact zero-order hold over a period ``T`` is
``z_{k+1} = e^{-ΓδT} z_k + (1 - e^{-ΓδT})/δ ξ_k``, written once in closed form
(:meth:`NNILaw.zoh_entries`, :meth:`NNILaw.zoh`).

Tuning coordinates (before the attitude loop's 3): ``ln kp``, the sector
coordinate (``u = ln(γ_max m kp δ)`` in the ``paper`` class, ``v = ln(m kp δ - 1)``
in the ``cascade`` class; :mod:`nniquad.laws.search_ranges`) and ``ln Γδ``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from nniquad.errors import GainError
from nniquad.laws.base import GainBlock, NILaw, TuningBox, gain_field, positive_gain
from nniquad.laws.registry import register
from nniquad.laws.search_ranges import GAMMA_DELTA_MIN, KP_RANGE, sector_coordinate_range

__all__ = ["Gains", "NNIGains", "PAPER_GAINS", "NNILaw", "NNI"]


@dataclass(frozen=True)
class Gains(GainBlock):
    """A gain set of the paper's controller (``controller = "nni"``).

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

    controller: ClassVar[str] = "nni"

    kp: float = gain_field("1/s^2", "inner-loop gain, x axis")
    Gamma: float = gain_field("-", "NNI controller gain Gamma", "Γ")
    delta: float = gain_field("-", "NNI controller parameter delta, C(0) = 1/delta", "δ")
    kpy: float | None = gain_field("1/s^2", "inner-loop gain, y axis (None: kp)", default=None)

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

    def values(self) -> dict[str, float]:
        """The numbers the simulator's parameter vector holds, in field order (``kpy`` resolved)."""
        return {"kp": self.kp, "Gamma": self.Gamma, "delta": self.delta, "kpy": self.kp_y}

    @classmethod
    def from_values(cls, values: Mapping[str, float]) -> "Gains":
        """Inverse of :meth:`values` (``kpy`` equal to ``kp`` becomes ``None``).

        Parameters
        ----------
        values
            ``{field: value}``.
        """
        kpy = values["kpy"]
        return cls(values["kp"], values["Gamma"], values["delta"], None if kpy == values["kp"] else kpy)

    def time_scaled(self, factor: float) -> "Gains":
        """The same loop ``factor`` times faster: ``k_p λ², Γ λ³, δ/λ²``.

        With ``ξ_λ(t) = ξ(λ t)`` and ``z_λ(t) = λ² z(λ t)`` the linear loop
        ``ξ'' = −k_p ξ + z/m``, ``z' = −Γδ z + Γ ξ`` maps onto itself; ``m k_p δ`` is
        unchanged, so the sector bound holds for every ``λ`` if it holds for one.

        Parameters
        ----------
        factor
            Speed-up λ > 0 (below 1: slower).
        """
        lam = positive_gain("time-scale factor", factor)
        return Gains(self.kp * lam**2, self.Gamma * lam**3, self.delta / lam**2,
                     None if self.kpy is None else self.kpy * lam**2)


#: The NNI law's gain block under the name of its law.
NNIGains = Gains

#: The paper's gains (Table "Simulation Parameters"): kp^x = kp^y = 5, Γ = 160, δ = 0.6.
PAPER_GAINS = Gains(kp=5.0, Gamma=160.0, delta=0.6)


class NNILaw(NILaw):
    """The paper's law (module docstring)."""

    name: ClassVar[str] = "nni"
    title: ClassVar[str] = "the paper's velocity-free law: inner loop kp and the integral resonant controller " \
                           "Gamma/(s + Gamma delta)"
    gains_type: ClassVar[type] = Gains
    state_names: ClassVar[tuple[str, ...]] = ("zc",)
    state_units: ClassVar[tuple[str, ...]] = ("N",)
    time_scaling: ClassVar[Mapping[str, int]] = {"kp": 2, "Gamma": 3, "delta": -2, "kpy": 2}
    pole_label: ClassVar[str] = "NNI controller (Gamma*delta)"
    pole_hint: ClassVar[str] = "Gamma or delta, or SimOptions.dt_s"
    gamma_formula: ClassVar[str] = "1/(m kp delta)"
    start_description: ClassVar[str] = "controller state 0"
    controller_label: ClassVar[str] = "NNI"
    display_name: ClassVar[str] = "NNI"
    default_gains: ClassVar[GainBlock] = PAPER_GAINS

    def kp(self, p: Mapping[str, Any], axis: int = 0) -> Any:
        return p["kp"] if axis == 0 else p.get("kpy", p["kp"])

    def controller_realisation(self, p: Mapping[str, Any]) -> tuple[list, list, list, list]:
        G, d = p["Gamma"], p["delta"]
        return [[-G * d]], [[G]], [[1]], [[0]]

    def dc_gain(self, gains: Gains) -> float:
        return 1.0 / gains.delta

    def dc_loop_gain(self, gains: Gains, m: float, kp: float) -> float:
        """``1/(m kp δ)``: the DC loop gain of one axis with inner gain ``kp``.

        Parameters
        ----------
        gains
            NNI gains.
        m
            The mass of the reduced loop [kg].
        kp
            The axis's (effective) inner gain [1/s²].
        """
        return 1.0 / (float(m) * float(kp) * gains.delta)

    def sector_limit(self, gains: Gains, m: float, kp: float, gamma: float) -> tuple[str, float]:
        # the paper's form of the bound: delta^2 >= 1/(gamma^2 m^2 min kp^2)
        return "delta_min", 1.0 / (float(gamma) * float(kp) * float(m))

    def sector_violation(self, gains: Gains, m: float, gamma_max: float) -> str:
        _, limit = self.sector_limit(gains, m, min(gains.axes()), gamma_max)
        return (f"delta = {gains.delta:.6g} < 1/(gamma_max m kp) = {limit:.6g} "
                f"(smallest gamma {self.sector_constant(gains, m):.6g} > gamma_max {gamma_max:g})")

    def sector_constant(self, gains: Gains, m: float) -> float:
        return max(self.dc_loop_gain(gains, m, kp) for kp in gains.axes())

    def gains_json(self, gains: Gains) -> dict[str, Any]:
        """The paper's section, ``kp, Gamma, delta`` (no ``controller`` key: the section of the first release).

        Parameters
        ----------
        gains
            NNI gains with equal axes.
        """
        return {"kp": gains.kp, "Gamma": gains.Gamma, "delta": gains.delta}

    @property
    def section_fields(self) -> tuple[str, ...]:
        return ("kp", "Gamma", "delta")

    def gains_from_json(self, section: Mapping[str, Any]) -> Gains:
        # the first release's section names no law: a section that names one is another law's
        if self.SECTION_LAW_KEY in section:
            raise GainError(f"the {self.name} law's section names no law, got {section[self.SECTION_LAW_KEY]!r}")
        return super().gains_from_json(section)

    def start_state(self, gains: Gains, m_hat: float, xi0: Sequence[float]) -> np.ndarray:
        return np.zeros(2)

    def zoh(self, gains: Gains, m_hat: float, T: float) -> tuple[np.ndarray, np.ndarray]:
        a = math.exp(-gains.Gamma * gains.delta * T)
        b = -math.expm1(-gains.Gamma * gains.delta * T) / gains.delta
        return a * np.eye(2), b * np.eye(2)

    def zoh_entries(self, p: Mapping[str, Any], T: Any, lib: Any, axis: int = 0) -> tuple[list, list]:
        gd_T = p["Gamma"] * p["delta"] * T
        return [[lib.exp(-gd_T)]], [[-lib.expm1(-gd_T) / p["delta"]]]

    def discretisation_text(self) -> str:
        return ("exact zero-order hold of C(s) = Gamma/(s + Gamma delta): "
                "A = exp(-Gamma delta T) I, B = (1 - exp(-Gamma delta T))/delta I")

    def export_matrix_units(self) -> dict[str, str]:
        return {"A": "-", "B": "N/m", "C": "1/kg", "D": "1/s^2"}

    def fastest_pole(self, gains: Gains, m_hat: float = 1.0) -> float:
        return float(gains.Gamma * gains.delta)

    def controller_scaling(self, gains: Gains) -> np.ndarray:
        return np.eye(1)

    def axis_scaling(self, gains: Gains, kp: float, m_nominal: float) -> np.ndarray:
        """``diag(1, sqrt(kp), Γ)``: the velocity in units of the inner loop's natural frequency, the controller
        state in units of Γ.

        Parameters
        ----------
        gains
            NNI gains.
        kp
            The axis's inner gain [1/s²].
        m_nominal
            The nominal mass [kg] (not used).
        """
        return np.diag([1.0, float(np.sqrt(kp)), gains.Gamma])

    def pm_ceiling_deg(self, gamma_max: float) -> float:
        """``asin(γ_max/(2 - γ_max))`` (41.8° at γ_max = 0.8).

        ``a_h = -k_p ξ + z/m``, ``z' = -Γδ z + Γ ξ`` is a lead compensator ``k_p (s + a)/(s + b)`` with
        ``a/b = 1 - 1/(m k_p δ)``; the sector bound ``m k_p δ >= 1/γ_max`` limits ``b/a`` to ``1/(1 - γ_max)``, so
        the phase lead, and with the double integrator's -180° the phase margin, is at most this.  The cascade's
        attitude loop, motor lag and sampling only take phase away.

        Parameters
        ----------
        gamma_max
            The sector bound's ceiling.
        """
        g = float(gamma_max)
        return math.degrees(math.asin(g / (2.0 - g)))

    def min_stable_mass(self, gains: Gains) -> float:
        return 1.0 / (min(gains.axes()) * gains.delta)

    # ------------------------------------------------------------------ tuning
    def coordinates(self, law_class: str | None) -> tuple[str, ...]:
        q1 = "u = ln(gamma_max m kp delta)" if self.check_class(law_class) == "paper" else "v = ln(m kp delta - 1)"
        return ("ln kp", q1, "ln Gamma delta")

    def box(self, law_class: str | None, limits: TuningBox) -> tuple[list[float], list[float]]:
        q1 = sector_coordinate_range(self.check_class(law_class))
        return ([math.log(KP_RANGE[0]), q1[0], math.log(GAMMA_DELTA_MIN)],
                [math.log(limits.kp_max), q1[1], math.log(limits.pole_max)])

    def decode(self, q: Sequence[float], m: float, gamma_max: float, law_class: str | None) -> Gains:
        kp = math.exp(q[0])
        paper = self.check_class(law_class) == "paper"
        mkd = math.exp(q[1]) / gamma_max if paper else 1.0 + math.exp(q[1])  # m kp delta
        delta = mkd / (m * kp)
        return Gains(kp=kp, Gamma=math.exp(q[2]) / delta, delta=delta)

    def encode(self, gains: Any, m: float, gamma_max: float, law_class: str | None) -> list[float]:
        if not isinstance(gains, Gains):
            raise ValueError(f"{type(gains).__name__} is not a gain block of the {self.name!r} law")
        mkd = m * gains.kp * gains.delta
        if self.check_class(law_class) == "paper":
            q1 = math.log(gamma_max * mkd)
        elif mkd > 1.0:
            q1 = math.log(mkd - 1.0)
        else:
            raise ValueError(f"m kp delta = {mkd:.6g} <= 1: outside the cascade class's coordinates")
        return [math.log(gains.kp), q1, math.log(gains.Gamma * gains.delta)]

    def sector_face(self, law_class: str | None) -> bool:
        return self.check_class(law_class) == "paper"

    def seed_from(self, gains: GainBlock, m_hat: float) -> Gains | None:
        """Another law's design as an NNI design: its NNI image (a filtered PD's, :mod:`nniquad.laws.pd_filtered`).

        Parameters
        ----------
        gains
            A gain block of any law.
        m_hat
            The controller's nominal mass [kg].
        """
        image = self.image_of(gains, m_hat)
        return image if isinstance(image, Gains) else None


#: The registered NNI law.
NNI = register(NNILaw())
