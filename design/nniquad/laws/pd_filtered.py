"""The PD law with a filtered derivative of the measured position, and why it is the NNI law (the maps both ways).

``a_h = -k_p ξ_m - k_d v̂`` with the velocity estimated from the measured position
by a first-order "dirty derivative" ``s/(τ_f s + 1)``, realised with one filter
state ``d`` per axis: ``d' = (ξ_m - d)/τ_f``, ``v̂ = (ξ_m - d)/τ_f``.  The filter
starts at the measured position, ``d(0) = ξ(0)`` (``v̂(0) = 0``, no derivative
kick); its exact zero-order hold over a period ``T`` is
``d_{k+1} = e^{-T/τ_f} d_k + (1 - e^{-T/τ_f}) ξ_k``.  Tuning coordinates: ``ln k_p``,
``ζ = k_d/(2 sqrt k_p)`` (the damping ratio on the double integrator) and ``ln τ_f``.

Tuned in a law class (``paper`` or ``cascade``), a filtered PD is the PD law
whose NNI image lies in the class's box (:meth:`PDFilteredLaw.image_violation`),
and it is certified as that image.

With the project's conventions (per axis ``a_h = -k_p' ξ + z/m̂``,
``z' = -Γδ z + Γ ξ``, the controller's nominal mass ``m̂``), the PD law with a
dirty derivative of the measured position,

.. math:: a_h = -k_p ξ - k_d \\frac{s}{τ_f s + 1} ξ
              = -\\Big(k_p + \\frac{k_d}{τ_f}\\Big) ξ + \\frac{k_d/τ_f^2}{s + 1/τ_f} ξ,

is the NNI law with

.. math:: k_p' = k_p + k_d/τ_f,\\qquad Γ = \\hat m k_d/τ_f^2,\\qquad δ = τ_f/(\\hat m k_d).

State by state: the filter state ``d`` (``d' = (ξ - d)/τ_f``, ``v̂ = (ξ - d)/τ_f``)
is ``z = d/δ = \\hat m k_d d/τ_f``, so the two laws give the same run from the
same start once the NNI state starts at ``z(0) = d(0)/δ``
(:func:`nni_start_state`; the PD filter starts at ``d(0) = ξ(0)``).  The
map back exists exactly when ``\\hat m k_p' δ > 1`` (then ``k_p = k_p' - 1/(\\hat m δ)
> 0``), which is the Routh condition of the reduced NNI loop: every stable
NNI gain set is a filtered PD and every filtered PD is a stable NNI gain set.

The paper's sector bound ``δ ≥ 1/(γ \\hat m k_p')`` reads, under the map,
``(k_p τ_f/k_d + 1) γ ≥ 1``: the smallest γ of a filtered PD is
``k_d/(k_p τ_f + k_d)`` (:func:`filtered_pd_gamma`), always below 1, and it
satisfies the bound with ``γ_max`` iff ``k_p τ_f/k_d ≥ 1/γ_max - 1`` (0.25 at the
paper's γ = 0.8).  ``nniquad.proofs.extensions`` checks all of this with sympy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from nniquad.errors import GainError
from nniquad.laws.base import ControlLaw, GainBlock, PlainGainBlock, TuningBox, gain_field, positive_gain
from nniquad.laws.classes import SECTOR_RTOL
from nniquad.laws.nni import NNI, Gains
from nniquad.laws.registry import register
from nniquad.laws.search_ranges import KP_RANGE, PD_ZETA_RANGE

__all__ = ["nni_from_filtered_pd", "filtered_pd_from_nni", "nni_start_state", "filtered_pd_gamma",
           "filtered_pd_in_sector", "PDFilteredGains", "DEFAULT_TAU_F_S", "PDFilteredLaw", "PD_FILTERED"]

#: Default time constant of the dirty-derivative filter of :class:`PDFilteredGains` [s].
DEFAULT_TAU_F_S = 0.02


@dataclass(frozen=True)
class PDFilteredGains(PlainGainBlock):
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

    kp: float = gain_field("1/s^2", "PD position gain")
    kd: float = gain_field("1/s", "PD derivative gain")
    tau_f: float = gain_field("s", "time constant of the derivative filter", "τ_f", default=DEFAULT_TAU_F_S)

    def time_scaled(self, factor: float) -> "PDFilteredGains":
        """The same loop ``factor`` times faster: ``k_p λ², k_d λ, τ_f/λ`` (``ξ_λ(t) = ξ(λ t)``).

        Parameters
        ----------
        factor
            Speed-up λ > 0.
        """
        lam = positive_gain("time-scale factor", factor)
        return PDFilteredGains(self.kp * lam**2, self.kd * lam, self.tau_f / lam)


def nni_from_filtered_pd(pd: PDFilteredGains, m_hat: float) -> Gains:
    """The NNI gain set that is the filtered-derivative PD law ``pd`` (module docstring).

    Parameters
    ----------
    pd
        The filtered PD gains ``k_p`` [1/s²], ``k_d`` [1/s], ``τ_f`` [s].
    m_hat
        The controller's nominal mass [kg] (the NNI output is divided by it).

    Returns
    -------
    Gains
        ``kp = k_p + k_d/τ_f``, ``Gamma = m̂ k_d/τ_f²``, ``delta = τ_f/(m̂ k_d)``.
    """
    if not isinstance(pd, PDFilteredGains):
        raise GainError(f"a filtered-derivative PD gain block is needed, got {type(pd).__name__}")
    m = positive_gain("nominal mass", m_hat)
    return Gains(kp=pd.kp + pd.kd / pd.tau_f, Gamma=m * pd.kd / pd.tau_f**2, delta=pd.tau_f / (m * pd.kd))


def filtered_pd_from_nni(gains: Gains, m_hat: float) -> PDFilteredGains:
    """The filtered-derivative PD law that is the NNI gain set ``gains`` (inverse of :func:`nni_from_filtered_pd`).

    Parameters
    ----------
    gains
        NNI gains with equal axes.
    m_hat
        The controller's nominal mass [kg].

    Returns
    -------
    PDFilteredGains
        ``τ_f = 1/(Γδ)``, ``k_d = 1/(m̂ Γ δ²)``, ``k_p = kp - 1/(m̂ δ)``.

    Raises
    ------
    GainError
        Unequal axis gains, or ``m̂ kp δ <= 1`` (the reduced loop is not stable and
        no filtered PD with ``k_p > 0`` is this law).
    """
    if not isinstance(gains, Gains):
        raise GainError(f"an NNI gain block is needed, got {type(gains).__name__}")
    if gains.kpy is not None and gains.kpy != gains.kp:
        raise GainError("a filtered PD has one gain for both axes: kpy must equal kp")
    m = positive_gain("nominal mass", m_hat)
    kp_static = gains.kp - 1.0 / (m * gains.delta)
    if not kp_static > 0:
        raise GainError(f"m kp delta = {m * gains.kp * gains.delta:.6g} <= 1: no filtered PD is this NNI law "
                        "(its reduced loop is not stable)")
    return PDFilteredGains(kp=kp_static, kd=1.0 / (m * gains.Gamma * gains.delta**2),
                           tau_f=1.0 / (gains.Gamma * gains.delta))


def nni_start_state(pd: PDFilteredGains, m_hat: float, d0_m: Sequence[float]) -> tuple[float, float]:
    """The NNI controller state ``z(0) = d(0)/δ`` [N] that starts as the PD filter state ``d(0)`` does.

    Parameters
    ----------
    pd
        The filtered PD gains.
    m_hat
        The controller's nominal mass [kg].
    d0_m
        The filter state at the start, per axis [m] (the simulator starts it at ``ξ(0)``).
    """
    delta = nni_from_filtered_pd(pd, m_hat).delta
    return (float(d0_m[0]) / delta, float(d0_m[1]) / delta)


def filtered_pd_gamma(pd: PDFilteredGains) -> float:
    """Smallest γ with which the NNI image of ``pd`` satisfies the sector bound: ``k_d/(k_p τ_f + k_d)`` (< 1).

    Independent of the mass (``1/(m̂ k_p' δ)`` with the map of the module docstring).

    Parameters
    ----------
    pd
        The filtered PD gains.
    """
    return pd.kd / (pd.kp * pd.tau_f + pd.kd)


def filtered_pd_in_sector(pd: PDFilteredGains, gamma_max: float) -> bool:
    """Whether the image of ``pd`` satisfies the sector bound with ``γ_max``: ``(k_p τ_f/k_d + 1) γ_max >= 1``.

    Parameters
    ----------
    pd
        The filtered PD gains.
    gamma_max
        The sector constant, in (0, 1).
    """
    return (pd.kp * pd.tau_f / pd.kd + 1.0) * float(gamma_max) >= 1.0 - SECTOR_RTOL


class PDFilteredLaw(ControlLaw):
    """The PD law with a filtered derivative (module docstring)."""

    name: ClassVar[str] = "pd_filtered"
    title: ClassVar[str] = "velocity-free PD: a dirty derivative s/(tau_f s + 1) of the measured position"
    gains_type: ClassVar[type] = PDFilteredGains
    state_names: ClassVar[tuple[str, ...]] = ("zc",)
    state_units: ClassVar[tuple[str, ...]] = ("m",)
    time_scaling: ClassVar[Mapping[str, int]] = {"kp": 2, "kd": 1, "tau_f": -1}
    pole_label: ClassVar[str] = "derivative filter (1/tau_f)"
    pole_hint: ClassVar[str] = "tau_f or SimOptions.dt_s"
    law_classes: ClassVar[tuple[str | None, ...]] = (None, "paper", "cascade")

    def realisation(self, p: Mapping[str, Any], axis: int = 0) -> tuple[list, list, list, list]:
        tau, kd = p["tau_f"], p["kd"]
        return [[-1 / tau]], [[1 / tau]], [[kd / tau]], [[-p["kp"] - kd / tau]]

    def sim_rates(self, p: Mapping[str, Any], meas: Sequence[Any], vel: Sequence[Any], xc: Sequence[Any],
                  discrete: Any, lib: Any) -> tuple[list, list]:
        # the realisation in its dirty-derivative form (the simulator's expression since the first release)
        v_hat = [(meas[a] - xc[a]) / p["tau_f"] for a in (0, 1)]
        return [-p["kp"] * meas[a] - p["kd"] * v_hat[a] for a in (0, 1)], v_hat

    def zoh_entries(self, p: Mapping[str, Any], T: Any, lib: Any, axis: int = 0) -> tuple[list, list]:
        a = lib.exp(-T / p["tau_f"])
        return [[a]], [[1 - a]]

    def start_state(self, gains: PDFilteredGains, m_hat: float, xi0: Sequence[float]) -> np.ndarray:
        return np.array([float(xi0[0]), float(xi0[1])])

    def static_stiffness(self, gains: PDFilteredGains, m_hat: float) -> tuple[float, float]:
        # the derivative term vanishes at rest
        return float(m_hat) * gains.kp, float(m_hat) * gains.kp

    def fastest_pole(self, gains: PDFilteredGains, m_hat: float = 1.0) -> float:
        return 1.0 / float(gains.tau_f)

    def ni_image(self, gains: PDFilteredGains, m_hat: float) -> Gains:
        return nni_from_filtered_pd(gains, m_hat)

    def in_class(self, law_class: str | None) -> bool:
        return law_class is not None

    # ------------------------------------------------------------------ tuning
    def coordinates(self, law_class: str | None) -> tuple[str, ...]:
        return ("ln k_p", "zeta = k_d/(2 sqrt k_p)", "ln tau_f")

    def box(self, law_class: str | None, limits: TuningBox) -> tuple[list[float], list[float]]:
        # a derivative filter faster than one sample period only passes the sampling steps: tau_f >= 1/f_s
        return ([math.log(KP_RANGE[0]), PD_ZETA_RANGE[0], math.log(1.0 / limits.control_rate_hz)],
                [math.log(limits.kp_max), PD_ZETA_RANGE[1], 0.0])

    def decode(self, q: Sequence[float], m: float, gamma_max: float, law_class: str | None) -> PDFilteredGains:
        kp = math.exp(q[0])
        return PDFilteredGains(kp=kp, kd=2.0 * float(q[1]) * math.sqrt(kp), tau_f=math.exp(q[2]))

    def encode(self, gains: Any, m: float, gamma_max: float, law_class: str | None) -> list[float]:
        if not isinstance(gains, PDFilteredGains):
            raise ValueError(f"{type(gains).__name__} is not a gain block of the {self.name!r} law")
        return [math.log(gains.kp), gains.kd / (2.0 * math.sqrt(gains.kp)), math.log(gains.tau_f)]

    def image_violation(self, gains: PDFilteredGains, m: float, gamma_max: float, law_class: str | None,
                        limits: TuningBox) -> float:
        """How far the NNI image (:func:`nni_from_filtered_pd`) lies outside the class's NNI box (0 inside):
        ``kp <= kp_max``, ``Γδ`` below the pole bound, the lower ends, and ``u >= 0`` (paper: the sector bound) or
        ``v >= V_RANGE[0]`` (cascade); the sum of the log-distances to the violated bounds.  Zero without a class.

        Parameters
        ----------
        gains
            Filtered PD gains.
        m
            Nominal mass [kg].
        gamma_max
            The sector bound's ceiling.
        law_class
            ``"paper"``, ``"cascade"`` or ``None``.
        limits
            The box's limits.
        """
        if law_class is None:
            return 0.0
        q = NNI.encode(nni_from_filtered_pd(gains, m), m, gamma_max, law_class)
        lo, hi = NNI.box(law_class, TuningBox(limits.kp_max, limits.pole_max, 1.0))
        return float(sum(max(0.0, lo[i] - q[i]) + max(0.0, q[i] - hi[i]) for i in range(3)))

    def seed_from(self, gains: GainBlock, m_hat: float) -> PDFilteredGains | None:
        """A filtered PD itself, or the filtered PD that is an NNI design (:func:`filtered_pd_from_nni`).

        Parameters
        ----------
        gains
            A gain block of any law.
        m_hat
            The controller's nominal mass [kg].
        """
        if isinstance(gains, PDFilteredGains):
            return gains
        if isinstance(gains, Gains):
            try:
                return filtered_pd_from_nni(gains, m_hat)
            except GainError:
                return None
        return None


#: The registered filtered-derivative PD law.
PD_FILTERED = register(PDFilteredLaw())
