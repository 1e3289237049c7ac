"""The tunable laws: a gains class, its search coordinates and its box, one :class:`Law` each.

A law class (:mod:`nniquad.control.law_classes`) says which theorem certifies
an NNI design; the tuner searches each class in its own coordinates:

=================  =====================  ============================================  ==============================
law                gains                  coordinates (before the attitude loop's 3)    what the box encodes
=================  =====================  ============================================  ==============================
``nni``/paper      :class:`Gains`         ``ln kp``, ``u = ln(γ_max m kp δ)``,          the sector bound is ``u >= 0``
                                          ``ln Γδ``
``nni``/cascade    :class:`Gains`         ``ln kp``, ``v = ln(m kp δ - 1)``,            the Routh condition
                                          ``ln Γδ``                                     ``m kp δ > 1`` is built in
``pd_velocity``    :class:`PDGains`       ``ln k_p``, ``ζ = k_d/(2√k_p)``               -
``pd_filtered``    :class:`PDFilteredGains`  ``ln k_p``, ``ζ``, ``ln τ_f``              with a class: the NNI image
                                                                                        (:mod:`nniquad.control.pd_equivalence`)
                                                                                        must lie in its box
``sni2``/paper     :class:`SNI2Gains`     ``ln kp``, ``u = ln(γ_max/γ)``, ``ln ω``,     the DC (sector) condition
                                          ``ln ζ``                                      ``γ = k/(m kp ω²) <= γ_max`` is
                                                                                        ``u >= 0``
``sni2``/cascade   :class:`SNI2Gains`     ``ln kp``, ``v = ln(1/γ - 1)``, ``ln ω``,     ``γ < 1`` built in
                                          ``ln ζ``
=================  =====================  ============================================  ==============================

The ``sni2`` law (:mod:`nniquad.control.sni`) reads its DC loop gain
``γ = k/(m kp ω²)`` in the NNI law's own coordinates (for the NNI law
``γ = 1/(m kp δ)``, so ``u`` and ``v`` mean the same in both).  Its box keeps
``ω <= π f_s`` (the resonance below the Nyquist frequency of the sampled position) and
``ζ`` in :data:`SNI2_ZETA_RANGE`, whose top keeps the faster real pole
``ω (ζ + sqrt(ζ² - 1))`` inside the RK4 step's stability region; at ``ζ = 4`` the law
is the NNI law followed by a low-pass 62 times faster than its pole
(:func:`nniquad.control.sni.sni2_from_nni`): the seeds from NNI and filtered-PD designs.

Why ``v`` for the cascade class: without the sector bound ``m kp δ`` runs down
to 1 (a filtered PD with a small ``k_p τ_f/k_d``: ``m kp δ - 1 = k_p τ_f/k_d``),
where ``u`` would crowd the designs into ``u -> ln γ_max``; ``v`` spreads them
(``v = ln(k_p τ_f/k_d)`` of the image), and the paper class is ``v >= ln(1/γ_max - 1)``.

A filtered PD tuned "in a class" (``TuneOptions.law_class``) is the PD law whose
NNI image satisfies the class's bounds: :meth:`Law.image_violation` says by how
much it does not (0 inside), and the objective ranks a violation above every
admissible cost.  Its coordinates stay the PD ones, so its search is the PD
tuner's with the class added; the NNI tuner is then seeded with its image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from nniquad.control.gains import ControllerGains, Gains, PDFilteredGains, PDGains, SNI2Gains
from nniquad.control.law_classes import LAW_CLASSES

__all__ = ["Law", "law_of", "LAWS", "KP_RANGE", "U_RANGE", "V_RANGE", "GAMMA_DELTA_MIN", "PD_ZETA_RANGE",
           "CASCADE_GAMMA_CAP", "SNI2_OMEGA_MIN", "SNI2_ZETA_RANGE", "sni2_omega_max"]

#: Bounds of the NNI coordinates that do not depend on the vehicle: kp [1/s^2], u, Gamma delta [1/s].
KP_RANGE: tuple[float, float] = (0.5, 2000.0)
U_RANGE: tuple[float, float] = (0.0, 4.0)
GAMMA_DELTA_MIN: float = 0.05
#: Largest sector constant the cascade class searches: m kp δ >= 1/0.995 (the static stiffness m kp δ - 1 of
#: the loop at least 0.5 % of m kp δ; below it a wind offset grows without bound).
CASCADE_GAMMA_CAP: float = 0.995
#: Range of v = ln(m kp δ - 1) of the cascade class: from the cap above to the paper class's u = 4 at γ_max 0.8.
V_RANGE: tuple[float, float] = (math.log(1.0 / CASCADE_GAMMA_CAP - 1.0), math.log(math.exp(U_RANGE[1]) / 0.8 - 1.0))
#: Damping ratio ``k_d / (2 √k_p)`` of a PD law on the double integrator: the search range.
PD_ZETA_RANGE: tuple[float, float] = (0.3, 2.0)
#: Smallest natural frequency ω of the ``sni2`` controller searched [rad/s].
SNI2_OMEGA_MIN: float = 0.5
#: Damping ratio ζ of the ``sni2`` controller searched: from a resonance (0.1) to real poles 62 : 1 apart (4).
SNI2_ZETA_RANGE: tuple[float, float] = (0.1, 4.0)


def sni2_omega_max(gamma_delta_max: float, rk4_pole_max: float) -> float:
    """Largest ω of the ``sni2`` box [rad/s]: the NNI pole bound (``π f_s`` and the RK4 limit), and the faster
    real pole ``ω (ζ + sqrt(ζ² - 1))`` at the top of :data:`SNI2_ZETA_RANGE` inside the RK4 limit.

    Parameters
    ----------
    gamma_delta_max
        The NNI law's largest controller pole [1/s] (:func:`nniquad.tuning.coordinates.gain_limits`).
    rk4_pole_max
        Largest pole the RK4 step integrates, ``config.RK4_STEP_LIMIT / dt`` [1/s].
    """
    z = SNI2_ZETA_RANGE[1]
    return min(gamma_delta_max, rk4_pole_max / (z + math.sqrt(z * z - 1.0)))


@dataclass(frozen=True)
class Law:
    """A tunable law: its gains class, coordinates and box (module docstring).

    Attributes
    ----------
    controller
        The gains class's law name (``"nni"``, ``"pd_velocity"``, ``"pd_filtered"``, ``"sni2"``).
    law_class
        ``"paper"`` or ``"cascade"`` (:data:`nniquad.control.law_classes.LAW_CLASSES`), or ``None``
        for a PD law tuned without a class.
    coordinates
        Names of the gain coordinates, in order.
    """

    controller: str
    law_class: str | None
    coordinates: tuple[str, ...]

    @property
    def dims(self) -> int:
        """Number of gain coordinates."""
        return len(self.coordinates)

    @property
    def sector_face(self) -> bool:
        """Whether the fastest designs sit on the face ``q1 = lo`` (the sector bound of the paper class).

        The initial design then puts a share of its points on that face
        (:func:`nniquad.tuning.search.initial_design`).
        """
        return self.controller in ("nni", "sni2") and self.law_class == "paper"

    def box(self, kp_max: float, gamma_delta_max: float, control_rate_hz: float,
            rk4_pole_max: float = math.inf) -> tuple[list[float], list[float]]:
        """Lower and upper ends of the gain coordinates.

        Parameters
        ----------
        kp_max
            Largest kp [1/s²] (:func:`nniquad.tuning.coordinates.gain_limits`).
        gamma_delta_max
            Largest controller pole Γδ [1/s].
        control_rate_hz
            The control rate [Hz]: a derivative filter faster than one sample period only passes the
            sampling steps, so τ_f >= 1/f_s.
        rk4_pole_max
            Largest pole the RK4 step integrates [1/s] (bounds the ``sni2`` law's faster pole,
            :func:`sni2_omega_max`).
        """
        if self.controller == "sni2":
            q1 = U_RANGE if self.law_class == "paper" else V_RANGE
            w_max = sni2_omega_max(gamma_delta_max, rk4_pole_max)
            return ([math.log(KP_RANGE[0]), q1[0], math.log(SNI2_OMEGA_MIN), math.log(SNI2_ZETA_RANGE[0])],
                    [math.log(kp_max), q1[1], math.log(w_max), math.log(SNI2_ZETA_RANGE[1])])
        if self.controller == "nni":
            q1 = U_RANGE if self.law_class == "paper" else V_RANGE
            return ([math.log(KP_RANGE[0]), q1[0], math.log(GAMMA_DELTA_MIN)],
                    [math.log(kp_max), q1[1], math.log(gamma_delta_max)])
        lo, hi = [math.log(KP_RANGE[0]), PD_ZETA_RANGE[0]], [math.log(kp_max), PD_ZETA_RANGE[1]]
        if self.controller == "pd_filtered":
            lo.append(math.log(1.0 / control_rate_hz))
            hi.append(0.0)
        return lo, hi

    def decode(self, q: Sequence[float], m: float, gamma_max: float) -> ControllerGains:
        """Gain coordinates -> gains (only the first :attr:`dims` entries of ``q`` are read)."""
        kp = math.exp(q[0])
        if self.controller == "sni2":
            gamma = gamma_max * math.exp(-q[1]) if self.law_class == "paper" else 1.0 / (1.0 + math.exp(q[1]))
            omega = math.exp(q[2])
            return SNI2Gains(kp=kp, k=gamma * m * kp * omega**2, omega=omega, zeta=math.exp(q[3]))
        if self.controller == "nni":
            mkd = math.exp(q[1]) / gamma_max if self.law_class == "paper" else 1.0 + math.exp(q[1])  # m kp delta
            delta = mkd / (m * kp)
            return Gains(kp=kp, Gamma=math.exp(q[2]) / delta, delta=delta)
        kd = 2.0 * float(q[1]) * math.sqrt(kp)
        if self.controller == "pd_velocity":
            return PDGains(kp=kp, kd=kd)
        return PDFilteredGains(kp=kp, kd=kd, tau_f=math.exp(q[2]))

    def encode(self, gains: ControllerGains, m: float, gamma_max: float) -> list[float]:
        """Gains -> gain coordinates (inverse of :meth:`decode`).

        Raises
        ------
        ValueError
            A gains block of another law, or (cascade class) ``m kp δ <= 1``.
        """
        if type(gains).controller != self.controller:
            raise ValueError(f"{type(gains).__name__} is not a gain block of the {self.controller!r} law")
        if isinstance(gains, SNI2Gains):
            gamma = gains.dc_loop_gain(m)
            if self.law_class == "paper":
                q1 = math.log(gamma_max / gamma)
            elif gamma < 1.0:
                q1 = math.log(1.0 / gamma - 1.0)
            else:
                raise ValueError(f"DC loop gain {gamma:.6g} >= 1: outside the cascade class's coordinates")
            return [math.log(gains.kp), q1, math.log(gains.omega), math.log(gains.zeta)]
        if isinstance(gains, Gains):
            mkd = m * gains.kp * gains.delta
            if self.law_class == "paper":
                q1 = math.log(gamma_max * mkd)
            elif mkd > 1.0:
                q1 = math.log(mkd - 1.0)
            else:
                raise ValueError(f"m kp delta = {mkd:.6g} <= 1: outside the cascade class's coordinates")
            return [math.log(gains.kp), q1, math.log(gains.Gamma * gains.delta)]
        q = [math.log(gains.kp), gains.kd / (2.0 * math.sqrt(gains.kp))]
        if isinstance(gains, PDFilteredGains):
            q.append(math.log(gains.tau_f))
        return q

    def image_violation(self, gains: ControllerGains, m: float, gamma_max: float, kp_max: float,
                        gamma_delta_max: float) -> float:
        """How far the NNI image of a filtered PD lies outside its class's box (0 inside; log units).

        Zero for every law but ``pd_filtered`` tuned in a class.  The image
        (:func:`nniquad.control.pd_equivalence.nni_from_filtered_pd`) must satisfy
        the class's bounds of the NNI box: ``kp <= kp_max``, ``Γδ <= Γδ_max``, the
        lower ends, and ``u >= 0`` (paper: the sector bound) or ``v >= V_RANGE[0]``
        (cascade).  The sum of the log-distances to the violated bounds.
        """
        if self.controller != "pd_filtered" or self.law_class is None:
            return 0.0
        from nniquad.control.pd_equivalence import nni_from_filtered_pd

        image = nni_from_filtered_pd(gains, m)
        q = law_of("nni", self.law_class).encode(image, m, gamma_max)
        lo, hi = law_of("nni", self.law_class).box(kp_max, gamma_delta_max, 1.0)
        return float(sum(max(0.0, lo[i] - q[i]) + max(0.0, q[i] - hi[i]) for i in range(3)))


#: Every law, by (controller, law class).
LAWS: dict[tuple[str, str | None], Law] = {
    ("nni", "paper"): Law("nni", "paper", ("ln kp", "u = ln(gamma_max m kp delta)", "ln Gamma delta")),
    ("nni", "cascade"): Law("nni", "cascade", ("ln kp", "v = ln(m kp delta - 1)", "ln Gamma delta")),
    ("pd_velocity", None): Law("pd_velocity", None, ("ln k_p", "zeta = k_d/(2 sqrt k_p)")),
    ("sni2", "paper"): Law("sni2", "paper", ("ln kp", "u = ln(gamma_max/gamma), gamma = k/(m kp omega^2)",
                                             "ln omega", "ln zeta")),
    ("sni2", "cascade"): Law("sni2", "cascade", ("ln kp", "v = ln(1/gamma - 1), gamma = k/(m kp omega^2)",
                                                 "ln omega", "ln zeta")),
}
for _cls in (None, *LAW_CLASSES):
    LAWS[("pd_filtered", _cls)] = Law("pd_filtered", _cls, ("ln k_p", "zeta = k_d/(2 sqrt k_p)", "ln tau_f"))


def law_of(controller: str, law_class: str | None = None) -> Law:
    """The :class:`Law` of a controller and law class (``nni`` or ``sni2`` without a class: ``paper``).

    Raises
    ------
    ValueError
        An unknown controller, or a class the controller has no law for.
    """
    if controller in ("nni", "sni2") and law_class is None:
        law_class = "paper"
    try:
        return LAWS[(controller, law_class)]
    except KeyError:
        raise ValueError(f"no tunable law {controller!r} in law class {law_class!r}") from None
