"""Typed gain blocks: the paper's NNI controller, the PD comparison laws and the inner loops.

Each block validates its numbers on construction (a one-line error naming the
gain).  Each horizontal-controller block names its law in the class attribute
``controller`` (``"nni"``, ``"pd_velocity"``, ``"pd_filtered"``, ``"sni2"``): the simulator
reads the law from the block's type, and the gain part of its parameter vector
from the block's fields (units in each field's ``metadata``,
:func:`field_unit`).
"""

from __future__ import annotations

import math
from dataclasses import Field, asdict, dataclass, field, fields
from typing import Any, ClassVar, Union

from nniquad.errors import GainError, SimulationError
from nniquad.validate import finite_number

__all__ = [
    "positive_gain",
    "field_unit",
    "gains_text",
    "Gains",
    "PAPER_GAINS",
    "PDGains",
    "PDFilteredGains",
    "SNI2Gains",
    "ControllerGains",
    "CONTROLLER_GAINS",
    "NI_LAWS",
    "DEFAULT_TAU_F_S",
    "InnerLoopGains",
    "DEFAULT_INNER_LOOP_GAINS",
]


def positive_gain(name: str, value: float) -> float:
    """``value`` as a finite positive float, else :class:`GainError` naming ``name``."""
    return finite_number(name, value, error=GainError, positive=True)


def _f(unit: str, meaning: str, **kw: Any) -> Any:
    """A dataclass field carrying its unit and meaning (read by the simulator's parameter layout)."""
    return field(metadata={"unit": unit, "meaning": meaning}, **kw)


def field_unit(f: Field) -> tuple[str, str]:
    """``(unit, meaning)`` of a gain-block field (``("-", name)`` when it has none)."""
    return str(f.metadata.get("unit", "-")), str(f.metadata.get("meaning", f.name))


@dataclass(frozen=True)
class Gains:
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

    kp: float = _f("1/s^2", "inner-loop gain, x axis")
    Gamma: float = _f("-", "NNI controller gain Gamma")
    delta: float = _f("-", "NNI controller parameter delta, C(0) = 1/delta")
    kpy: float | None = _f("1/s^2", "inner-loop gain, y axis (None: kp)", default=None)

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
    def from_values(cls, values: dict[str, float]) -> "Gains":
        """Inverse of :meth:`values` (``kpy`` equal to ``kp`` becomes ``None``)."""
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


#: The paper's gains (Table "Simulation Parameters"): kp^x = kp^y = 5, Γ = 160, δ = 0.6.
PAPER_GAINS = Gains(kp=5.0, Gamma=160.0, delta=0.6)

#: Default time constant of the dirty-derivative filter of :class:`PDFilteredGains` [s].
DEFAULT_TAU_F_S = 0.02


class _PlainBlock:
    """``values`` / ``from_values`` / ``as_dict`` for blocks whose fields are all plain positive numbers."""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            object.__setattr__(self, f.name, positive_gain(f.name, getattr(self, f.name)))

    def values(self) -> dict[str, float]:
        """The numbers the simulator's parameter vector holds, in field order."""
        return {f.name: getattr(self, f.name) for f in fields(self)}  # type: ignore[arg-type]

    def as_dict(self) -> dict[str, float]:
        """Plain dictionary of the gains."""
        return self.values()

    @classmethod
    def from_values(cls, values: dict[str, float]):
        """Inverse of :meth:`values`."""
        return cls(**{f.name: values[f.name] for f in fields(cls)})  # type: ignore[arg-type]


@dataclass(frozen=True)
class PDGains(_PlainBlock):
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

    kp: float = _f("1/s^2", "PD position gain")
    kd: float = _f("1/s", "PD derivative gain")

    def time_scaled(self, factor: float) -> "PDGains":
        """The same loop ``factor`` times faster: ``k_p λ², k_d λ`` (``ξ_λ(t) = ξ(λ t)``).

        Parameters
        ----------
        factor
            Speed-up λ > 0.
        """
        lam = positive_gain("time-scale factor", factor)
        return PDGains(self.kp * lam**2, self.kd * lam)


@dataclass(frozen=True)
class PDFilteredGains(_PlainBlock):
    """PD law with the velocity from a dirty derivative ``s/(τ_f s + 1)`` of the measured position.

    ``controller = "pd_filtered"``: ``a_h = -k_p ξ_m - k_d v̂``.

    Attributes
    ----------
    kp
        Position gain [1/s²] (> 0).
    kd
        Derivative gain [1/s] (> 0).
    tau_f
        Time constant of the derivative filter [s] (> 0; default :data:`DEFAULT_TAU_F_S`).
    """

    controller: ClassVar[str] = "pd_filtered"

    kp: float = _f("1/s^2", "PD position gain")
    kd: float = _f("1/s", "PD derivative gain")
    tau_f: float = _f("s", "time constant of the derivative filter", default=DEFAULT_TAU_F_S)

    def time_scaled(self, factor: float) -> "PDFilteredGains":
        """The same loop ``factor`` times faster: ``k_p λ², k_d λ, τ_f/λ`` (``ξ_λ(t) = ξ(λ t)``).

        Parameters
        ----------
        factor
            Speed-up λ > 0.
        """
        lam = positive_gain("time-scale factor", factor)
        return PDFilteredGains(self.kp * lam**2, self.kd * lam, self.tau_f / lam)


@dataclass(frozen=True)
class SNI2Gains(_PlainBlock):
    """The NNI structure with a second-order strictly negative-imaginary controller (``controller = "sni2"``).

    Per axis ``a_h = -k_p ξ_m + z/m̂`` with ``z = C(s) ξ_m``, ``C(s) = k/(s² + 2ζω s + ω²)``
    (:mod:`nniquad.control.sni`: the realisation, the DC condition ``k/(m̂ k_p ω²) < 1`` and the exact
    ZOH).  Velocity-free, like the NNI law; two controller states per axis.

    Attributes
    ----------
    kp
        Inner-loop proportional gain [1/s²] (both axes).
    k
        Gain of ``C(s)`` [N/(m s²)] (``C(0) = k/ω²`` N/m).
    omega
        Natural frequency ω of ``C(s)`` [rad/s].
    zeta
        Damping ratio ζ of ``C(s)`` (> 0: strictly negative imaginary).
    """

    controller: ClassVar[str] = "sni2"

    kp: float = _f("1/s^2", "inner-loop gain")
    k: float = _f("N/(m s^2)", "gain of the SNI controller C(s) = k/(s^2 + 2 zeta omega s + omega^2)")
    omega: float = _f("rad/s", "natural frequency of C(s)")
    zeta: float = _f("-", "damping ratio of C(s)")

    def axes(self) -> tuple[float, float]:
        """``(kpx, kpy)``: one gain for both axes."""
        return self.kp, self.kp

    def dc_loop_gain(self, m_hat: float) -> float:
        """``k/(m̂ k_p ω²)``, the DC loop gain γ of the NI theorem (:func:`nniquad.control.sni.dc_loop_gain`)."""
        from nniquad.control.sni import dc_loop_gain

        return dc_loop_gain(m_hat, self.kp, self.k, self.omega)

    def time_scaled(self, factor: float) -> "SNI2Gains":
        """The same loop ``factor`` times faster: ``k_p λ², k λ⁴, ω λ``, ζ unchanged (``z_λ(t) = λ² z(λ t)``).

        The DC loop gain ``k/(m k_p ω²)`` is unchanged.

        Parameters
        ----------
        factor
            Speed-up λ > 0.
        """
        lam = positive_gain("time-scale factor", factor)
        return SNI2Gains(self.kp * lam**2, self.k * lam**4, self.omega * lam, self.zeta)


#: Any horizontal-controller gain block.
ControllerGains = Union[Gains, PDGains, PDFilteredGains, SNI2Gains]


def wind_equilibrium_m(gains: ControllerGains, m_hat: float, wind_N: tuple[float, float]) -> tuple[float, float]:
    """Static position under a constant horizontal force, ``F / k`` per axis (origin where ``k <= 0``).

    The static stiffness ``k`` is ``m̂ k_p − 1/δ`` for the NNI law (its state settles
    at ``z = ξ/δ``), ``m̂ k_p − k/ω²`` for the ``sni2`` law (``z = C(0) ξ``) and ``m̂ k_p`` for the PD laws (the derivative term vanishes at rest).

    Parameters
    ----------
    gains
        The horizontal law's gain block.
    m_hat
        Mass the controller assumes [kg].
    wind_N
        Constant force ``(F_x, F_y)`` [N].
    """
    if isinstance(gains, Gains):
        stiffness = [m_hat * kp - 1.0 / gains.delta for kp in (gains.kp, gains.kp_y)]
    elif isinstance(gains, SNI2Gains):  # z settles at C(0) ξ = (k/ω²) ξ
        stiffness = [m_hat * gains.kp - gains.k / gains.omega**2] * 2
    else:
        stiffness = [m_hat * gains.kp] * 2
    x, y = (f / k if k > 0 else 0.0 for f, k in zip(wind_N, stiffness))
    return (x, y)
_GREEK = {"Gamma": "Γ", "delta": "δ", "omega": "ω", "zeta": "ζ", "tau_f": "τ_f"}


def gains_text(gains: ControllerGains, *, sep: str = " ", greek: bool = False, number: Any = None) -> str:
    """One line of a gain block's numbers, ``name=value``, for messages, tables and figure titles.

    Parameters
    ----------
    gains
        Any horizontal-controller gain block.
    sep
        Separator of the entries.
    greek
        Greek letters for the names (``Γ, δ, ω, ζ, τ_f``), and the NNI law's ``kpy`` left out when it is ``kp``
        (figure titles).
    number
        Formats a value (default ``format(v, "g")``).
    """
    fmt_ = number or (lambda v: f"{v:g}")
    items = gains.as_dict()
    if greek and items.get("kpy") == items.get("kp"):
        items = {k: v for k, v in items.items() if k != "kpy"}
    return sep.join(f"{_GREEK.get(k, k) if greek else k}={fmt_(v)}" for k, v in items.items() if v is not None)


#: The gain block of each controller law, by name.
CONTROLLER_GAINS: dict[str, type] = {cls.controller: cls for cls in (Gains, PDGains, PDFilteredGains, SNI2Gains)}
#: The laws of the NNI structure (a proportional inner loop and an SNI controller in positive feedback):
#: their closed loop has the NI certificates, the sector (DC) condition and the cascade certificate.
NI_LAWS: tuple[str, ...] = ("nni", "sni2")


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

    attitude_wn_rad_s: float = _f("rad/s", "attitude natural frequency", default=25.0)
    attitude_zeta: float = _f("-", "attitude damping ratio", default=0.8)
    yaw_wn_rad_s: float = _f("rad/s", "yaw-hold natural frequency", default=8.0)
    yaw_zeta: float = _f("-", "yaw-hold damping ratio", default=0.8)
    altitude_wn_rad_s: float = _f("rad/s", "altitude PID triple-pole frequency", default=3.0)
    attitude_gain_scale: float = _f("-", "factor on the attitude torques (gain error)", default=1.0)
    attitude_accel_limit_rad_s2: float = _f("rad/s^2", "angular-acceleration limit of the attitude error shaping",
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
        return asdict(self)

    def values(self) -> dict[str, float]:
        """The numbers the simulator's parameter vector holds, in field order."""
        return asdict(self)

    @classmethod
    def from_values(cls, values: dict[str, float]) -> "InnerLoopGains":
        """Inverse of :meth:`values`."""
        return cls(**{f.name: values[f.name] for f in fields(cls)})


DEFAULT_INNER_LOOP_GAINS = InnerLoopGains()
