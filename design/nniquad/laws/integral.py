"""Integral action on a law of the NI structure: the laws ``nni_i`` and ``sni2_i``.

Per axis the base law ``a_h = -k_p ξ + z/m̂``, ``z = C(s) ξ`` (:class:`nniquad.laws.base.NILaw`) gets an
integrator of the position error, ``q̇ = ξ`` (``q`` [m s], the simulator's ``zci_x``, ``zci_y``):

.. math:: a_h = -k_p ξ + z/\\hat m - k_i q, \\qquad \\frac{a_h}{ξ}(s) = -k_p - \\frac{k_i}{s} + \\frac{C(s)}{\\hat m}.

The realisation is the base controller ``(A_c, B_c, C_c, D_c)`` augmented with ``q``: ``A = diag(A_c, 0)``,
``B = [B_c; 1]``, and the force output gets ``-m̂ k_i q``, so the command's output row is
``[C_c/m̂, -k_i]`` (:meth:`IntegralLaw.realisation`).  The DC gain from position to command is infinite: the
static stiffness is infinite and a constant horizontal force leaves no offset (the equilibrium is the
setpoint, with ``q = F/(m̂ k_i)`` holding it), where the base law stops at ``F/(m̂ k_p (1 - γ))``.

Why only the ``cascade`` class
------------------------------
``-m̂ k_i/s`` is not negative imaginary (``Im(-m̂ k_i/(jν)) = m̂ k_i/ν > 0``) and ``C(0)`` is infinite, so the
paper's sector theorem does not apply (:attr:`ni_structure` is False, :meth:`sector_constant` is infinite):
a design is certified by the sampled-data cascade certificate alone.

Anti-windup (back-calculation, tracking time ``T_t = k_s/k_i``)
---------------------------------------------------------------
With the tilt limit's excess ``ψ = a_h - sat(a_h)`` (per axis, of the total command, feedforward included) and
``k_s = k_p - C(0)/m̂ = k_p (1 - γ)``, the base law's static stiffness per unit mass:

.. math:: \\dot q = ξ + ψ/k_s.

It is linear in the dead zone ψ, so the Lur'e region of the cascade certificate covers it as it is
(conditional integration is a switch outside that framework).  Why ``k_s`` and not ``k_p``: during a long
saturated approach the base controller settles near its DC value and hands ``γ k_p ξ`` back, so the command
before the limit is about ``-k_s ξ``; the excess is then ``k_s ξ - L`` and the integrator sees
``q̇ = L/k_s``, the error clipped to the zone where the base law's static command is not limited.  With
``1/k_p`` instead it would still wind at about ``γ ξ`` (``docs/notes/laws.md`` gives the measured overshoots).
The law exposes the gain through :meth:`IntegralLaw.anti_windup_gains` (``1/k_s`` on ``q``, 0 on the base's
states): the simulator, the discrete controller, the cascade family and the C export add it.

Discrete law (the certified one, period ``T``): the exact zero-order hold of the realisation plus the
anti-windup term, with the excess of the command held over the period,

.. math:: x^+ = A_d x + B_d ξ_k + E ψ_k, \\qquad q^+ = q + T (ξ_k + ψ_k/k_s),

i.e. in the family's form ``x⁺ = A_0 x + B_s sat(Kx) + E (Kx - sat(Kx))`` with ``E = T/k_s`` on the ``q``
rows and 0 elsewhere (``q`` has no dynamics of its own, so its ZOH is exact: ``q⁺ = q + T ξ_k``).

Start (bumpless take-over): the base law's start state and ``q(0) = 0``, so the first command is the base
law's take-over command.

Tuning coordinates: the base law's (in the ``cascade`` class) and ``ln(k_i/k_p^{3/2})``.  The ratio
``k_i/k_p^{3/2} = ω_i/ω_n`` compares the integral zero of ``k_p + k_i/s`` (``ω_i = k_i/k_p``) with the inner
loop's natural frequency ``ω_n = √k_p``, near which the loop crosses over; it is invariant under the time
scaling (``k_i λ³``, ``k_p^{3/2} λ³``), so one box serves every vehicle.  :data:`KI_RATIO_RANGE`: from
``10⁻³`` (the integral zero a thousand times below ``ω_n``: a wind offset removed on a time scale of about a
thousand inner-loop time constants, the slowest worth searching) to ``1`` (the zero at ``ω_n``: the
integrator's 45° phase lag at crossover, beyond which the loop's phase margin is gone).

Seed from a base design (:meth:`IntegralLaw.seed_from`): ``k_i`` such that the integrator's closed-loop pole,
``-k_i/k_s`` for small ``k_i`` (``k_s = k_p(1 - γ)``, the base's static stiffness per unit mass: root locus
from the origin), sits :data:`KI_SEED_SEPARATION` times slower than the slowest closed-loop pole of the base's
reduced loop (the integral zero well below crossover, so the base's transient is left almost as it was);
clipped to the box.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from nniquad.errors import GainError
from nniquad.laws.base import ControlLaw, GainBlock, NILaw, PlainGainBlock, TuningBox, gain_field
from nniquad.laws.nni import NNI
from nniquad.laws.registry import register
from nniquad.laws.sni2 import SNI2

__all__ = ["IntegralLaw", "NNIIntegralGains", "SNI2IntegralGains", "NNI_I", "SNI2_I", "integral_variant",
           "KI_RATIO_RANGE", "KI_SEED_SEPARATION", "reduced_loop_poles", "static_command_stiffness"]

#: Range of ``k_i/k_p^{3/2}`` (the integral zero over the inner loop's natural frequency) searched (module docstring).
KI_RATIO_RANGE: tuple[float, float] = (1e-3, 1.0)
#: The seed's integrator pole is this many times slower than the base loop's slowest pole (module docstring).
KI_SEED_SEPARATION: float = 5.0

_KI_META = ("1/s^3", "integral gain: a_h gets -ki q, q' = xi (anti-windup: + excess/ks, ks = kp (1 - gamma))", "k_i")


@dataclass(frozen=True)
class NNIIntegralGains(PlainGainBlock):
    """Gains of the ``nni_i`` law: the NNI law's (equal axes) and the integral gain.

    Attributes
    ----------
    kp
        Inner-loop proportional gain [1/s²] (both axes).
    Gamma
        Integral resonant controller gain Γ.
    delta
        Integral resonant controller parameter δ (``C(0) = 1/δ``).
    ki
        Integral gain [1/s³] (both axes): ``a_h`` gets ``-k_i q``, ``q̇ = ξ``.
    """

    controller: ClassVar[str] = "nni_i"

    kp: float = gain_field("1/s^2", "inner-loop gain")
    Gamma: float = gain_field("-", "NNI controller gain Gamma", "Γ")
    delta: float = gain_field("-", "NNI controller parameter delta, C(0) = 1/delta", "δ")
    ki: float = gain_field(*_KI_META)


@dataclass(frozen=True)
class SNI2IntegralGains(PlainGainBlock):
    """Gains of the ``sni2_i`` law: the ``sni2`` law's and the integral gain.

    Attributes
    ----------
    kp
        Inner-loop proportional gain [1/s²] (both axes).
    k
        Gain of ``C(s) = k/(s² + 2ζωs + ω²)`` [N/(m s²)].
    omega
        Natural frequency ω of ``C(s)`` [rad/s].
    zeta
        Damping ratio ζ of ``C(s)``.
    ki
        Integral gain [1/s³] (both axes): ``a_h`` gets ``-k_i q``, ``q̇ = ξ``.
    """

    controller: ClassVar[str] = "sni2_i"

    kp: float = gain_field("1/s^2", "inner-loop gain")
    k: float = gain_field("N/(m s^2)", "gain of the SNI controller C(s) = k/(s^2 + 2 zeta omega s + omega^2)")
    omega: float = gain_field("rad/s", "natural frequency of C(s)", "ω")
    zeta: float = gain_field("-", "damping ratio of C(s)", "ζ")
    ki: float = gain_field(*_KI_META)


def reduced_loop_poles(law: ControlLaw, gains: GainBlock, m_hat: float) -> np.ndarray:
    """The poles of one axis of the reduced loop ``ξ'' = a_h`` closed by ``law`` (nominal mass, no limit) [1/s].

    Parameters
    ----------
    law
        A velocity-free law.
    gains
        A gain block of it.
    m_hat
        The nominal mass [kg].
    """
    A, B, C, D = law.matrices(gains, m_hat, 0)
    n = A.shape[0]
    M = np.zeros((n + 2, n + 2))
    M[0, 1] = 1.0
    M[1, 0], M[1, 2:] = D[0, 0], C[0]
    M[2:, 0], M[2:, 2:] = B[:, 0], A
    return np.linalg.eigvals(M)


def static_command_stiffness(A: Sequence[Sequence[Any]], B: Sequence[Sequence[Any]], C: Sequence[Sequence[Any]],
                             D: Sequence[Sequence[Any]]) -> Any:
    """``-(D - C A⁻¹ B)`` of a one-input law's command realisation given as entries (numbers or CasADi expressions).

    Cramer's rule for the one- and two-state controllers the NI laws have, so the same expression serves the
    simulator's symbols and numbers.

    Parameters
    ----------
    A, B, C, D
        The realisation's entries (the first input column, the command row).

    Raises
    ------
    ValueError
        A controller of more than two states.
    """
    n = len(A)
    if n == 1:
        inv_b = [B[0][0] / A[0][0]]
    elif n == 2:
        det = A[0][0] * A[1][1] - A[0][1] * A[1][0]
        inv_b = [(A[1][1] * B[0][0] - A[0][1] * B[1][0]) / det, (A[0][0] * B[1][0] - A[1][0] * B[0][0]) / det]
    else:
        raise ValueError(f"the integral wrapper takes controllers of one or two states, not {n}")
    return -(D[0][0] - sum(C[0][i] * inv_b[i] for i in range(n)))


class IntegralLaw(ControlLaw):
    """A base law of the NI structure with an integrator of the position error (module docstring).

    Parameters
    ----------
    base
        The registered base law.
    gains_type
        The gains dataclass: the base's fields and ``ki``, named after this law.
    """

    integral: ClassVar[bool] = True
    ni_structure: ClassVar[bool] = False
    law_classes: ClassVar[tuple[str | None, ...]] = ("cascade",)

    def __init__(self, base: NILaw, gains_type: type) -> None:
        self.base = base
        self.name = gains_type.controller
        self.gains_type = gains_type
        self.title = f"{base.title}, plus integral action ki/s on the position (anti-windup)"
        self.state_names = (*base.state_names, "zci")
        self.state_units = (*base.state_units, "m s")
        self.time_scaling = {**base.time_scaling, "ki": 3}
        self.pole_label, self.pole_hint = base.pole_label, base.pole_hint
        self.robust_budget_overrides = base.robust_budget_overrides
        self.start_description = f"{base.start_description}; integrator q = 0"
        self.controller_label = f"{base.controller_label} with integral action"
        self.display_name = f"{base.display_name} + integral"
        super().__init__()

    # ------------------------------------------------------------------ gains
    def base_gains(self, gains: GainBlock) -> GainBlock:
        """The base law's gains of a design (``ki`` left out).

        Parameters
        ----------
        gains
            A gain block of this law.
        """
        names = self.base.gain_names
        return self.base.gains_type(**{f.name: getattr(gains, f.name) for f in fields(gains) if f.name in names})

    def with_ki(self, base_gains: GainBlock, ki: float) -> GainBlock:
        """The design of this law made of a base design and an integral gain.

        Parameters
        ----------
        base_gains
            A gain block of the base law (equal axes).
        ki
            The integral gain [1/s³].

        Raises
        ------
        GainError
            A base design of another law, or with two axis gains (the integral laws have one ``kp``).
        """
        base = self.base.gains(base_gains)
        if len(set(base.axes())) != 1:
            raise GainError(f"the {self.name} law has one kp for both axes, got {base.axes()}")
        values = {k: v for k, v in base.as_dict().items() if k in self.gain_names}
        return self.gains_type(**values, ki=ki)

    def _base_p(self, p: Mapping[str, Any]) -> dict[str, Any]:
        """The base law's parameter entries (its second-axis gain, where it has one, equal to ``kp``)."""
        return {**{k: v for k, v in p.items() if k != "ki"}, **({"kpy": p["kp"]} if "kpy" in self.base.gain_names
                                                                  else {})}

    # ------------------------------------------------------------------ realisation
    def realisation(self, p: Mapping[str, Any], axis: int = 0) -> tuple[list, list, list, list]:
        A, B, C, D = self.base.realisation(self._base_p(p), axis)
        n = self.base.n_states
        return ([list(r) + [0] for r in A] + [[0] * (n + 1)], [list(r) for r in B] + [[1]],
                [list(C[0]) + [-p["ki"]]], [list(D[0])])

    def anti_windup_gains(self, p: Mapping[str, Any], axis: int = 0) -> list:
        """``1/k_s`` on ``q`` and 0 on the base's states: ``ẋ_c`` gets this times the axis's excess ``a_h - sat(a_h)``.

        ``k_s = k_p - C(0)/m̂`` is the base law's static stiffness per unit mass, the DC gain of its command
        ``-(D - C A⁻¹ B)``, written from the realisation's entries so it serves numbers and expressions alike.

        Parameters
        ----------
        p
            The gains by name and ``m_hat`` (numbers or expressions).
        axis
            0 or 1.
        """
        A, B, C, D = self.base.realisation(self._base_p(p), axis)
        return [0.0] * self.base.n_states + [1.0 / static_command_stiffness(A, B, C, D)]

    def sim_rates(self, p: Mapping[str, Any], meas: Sequence[Any], vel: Sequence[Any], xc: Sequence[Any],
                  discrete: Any, lib: Any) -> tuple[list, list]:
        # the base's expressions unchanged, then -ki q and q' = xi (the anti-windup is the simulator's: it needs sat)
        nb = 2 * self.base.n_states
        a_h, dx = self.base.sim_rates(self._base_p(p), meas, vel, xc[:nb], discrete, lib)
        return [a_h[a] - p["ki"] * xc[nb + a] for a in (0, 1)], [*dx, meas[0], meas[1]]

    def zoh(self, gains: GainBlock, m_hat: float, T: float) -> tuple[np.ndarray, np.ndarray]:
        Ab, Bb = self.base.zoh(self.base_gains(gains), m_hat, T)
        nb = Ab.shape[0]
        Ad, Bd = np.eye(nb + 2), np.zeros((nb + 2, 2))
        Ad[:nb, :nb], Bd[:nb], Bd[nb:] = Ab, Bb, float(T) * np.eye(2)
        return Ad, Bd

    def zoh_entries(self, p: Mapping[str, Any], T: Any, lib: Any, axis: int = 0) -> tuple[list, list]:
        Ab, Bb = self.base.zoh_entries(self._base_p(p), T, lib, axis)
        n = self.base.n_states
        return [list(r) + [0] for r in Ab] + [[0] * n + [1]], [list(r) for r in Bb] + [[T]]

    def discretisation_text(self) -> str:
        return (f"the {self.base.name} law's states: {self.base.discretisation_text()}; then per axis the integrator "
                f"q[k+1] = q[k] + T (xi[k] + (a[k] - sat(a[k]))/ks), ks = kp (1 - gamma) the base's static stiffness per unit mass (its exact ZOH plus the back-calculation "
                f"anti-windup, a[k] the command before the tilt limit, sat(a[k]) after it); the whole state in the "
                f"order {', '.join(self.sim_state_names)}")

    def export_matrix_units(self) -> dict[str, str]:
        u = self.base.export_matrix_units()
        return {"A": f"{u['A']}; q: -", "B": f"{u['B']}; q: s", "C": f"{u['C']}; q: 1/s^3", "D": u["D"]}

    def fastest_pole(self, gains: GainBlock, m_hat: float = 1.0) -> float | None:
        return self.base.fastest_pole(self.base_gains(gains), m_hat)

    def start_state(self, gains: GainBlock, m_hat: float, xi0: Sequence[float]) -> np.ndarray:
        return np.concatenate([self.base.start_state(self.base_gains(gains), m_hat, xi0), np.zeros(2)])

    # ------------------------------------------------------------------ statics
    def dc_gain(self, gains: GainBlock) -> float:
        """``C(0)`` of the augmented controller: infinite (the integrator).

        Parameters
        ----------
        gains
            A gain block of this law.
        """
        return math.inf

    def sector_constant(self, gains: GainBlock, m: float) -> float:
        """The DC loop gain: infinite, no sector bound holds (the paper's theorem does not apply).

        Parameters
        ----------
        gains
            A gain block of this law.
        m
            The mass [kg].
        """
        return math.inf

    def static_stiffness(self, gains: GainBlock, m_hat: float) -> tuple[float, float]:
        return math.inf, math.inf

    def pm_ceiling_deg(self, gamma_max: float) -> float:
        """The base law's ceiling (:meth:`nniquad.laws.base.NILaw.pm_ceiling_deg`), still an upper bound: the
        integrator adds ``-j k_i/ν`` to the lead ``k_p - C(jν)/m̂`` (positive real part), which only lowers its phase.

        Parameters
        ----------
        gamma_max
            The sector bound's ceiling.
        """
        return self.base.pm_ceiling_deg(gamma_max)

    # ------------------------------------------------------------------ tuning
    def coordinates(self, law_class: str | None) -> tuple[str, ...]:
        return (*self.base.coordinates(self.check_class(law_class)), "ln(ki/kp^1.5)")

    def box(self, law_class: str | None, limits: TuningBox) -> tuple[list[float], list[float]]:
        lo, hi = self.base.box(self.check_class(law_class), limits)
        return [*lo, math.log(KI_RATIO_RANGE[0])], [*hi, math.log(KI_RATIO_RANGE[1])]

    def decode(self, q: Sequence[float], m: float, gamma_max: float, law_class: str | None) -> GainBlock:
        cls = self.check_class(law_class)
        nb = self.base.dims(cls)
        base = self.base.decode(q[:nb], m, gamma_max, cls)
        return self.with_ki(base, math.exp(q[nb]) * base.kp**1.5)

    def encode(self, gains: Any, m: float, gamma_max: float, law_class: str | None) -> list[float]:
        if not isinstance(gains, self.gains_type):
            raise ValueError(f"{type(gains).__name__} is not a gain block of the {self.name!r} law")
        base = self.base.encode(self.base_gains(gains), m, gamma_max, self.check_class(law_class))
        return [*base, math.log(gains.ki / gains.kp**1.5)]

    def seed_ki(self, base_gains: GainBlock, m_hat: float) -> float:
        """The seed's integral gain for a base design (module docstring), clipped to the box.

        Parameters
        ----------
        base_gains
            A gain block of the base law.
        m_hat
            The nominal mass [kg].
        """
        slowest = float(np.min(np.abs(reduced_loop_poles(self.base, base_gains, m_hat).real)))
        k_s = min(self.base.static_stiffness(base_gains, m_hat)) / float(m_hat)
        kp15 = base_gains.kp**1.5
        ki = k_s * slowest / KI_SEED_SEPARATION
        return min(max(ki, KI_RATIO_RANGE[0] * kp15), KI_RATIO_RANGE[1] * kp15)

    def seed_from(self, gains: GainBlock, m_hat: float) -> GainBlock | None:
        # a design of this law is itself; any other is the base law's seed (equal axes) with seed_ki
        if isinstance(gains, self.gains_type):
            return gains
        base = gains if isinstance(gains, self.base.gains_type) else self.base.seed_from(gains, m_hat)
        if base is None or len(set(base.axes())) != 1:
            return None  # no base design, or one with two axis gains
        return self.with_ki(base, self.seed_ki(base, m_hat))


def integral_variant(law: ControlLaw) -> ControlLaw:
    """The integral variant of a law (the law itself if it is one).

    Parameters
    ----------
    law
        A registered law.

    Raises
    ------
    ValueError
        The law has no integral variant (one line).
    """
    if law.integral:
        return law
    for variant in (NNI_I, SNI2_I):
        if variant.base is law:
            return variant
    raise ValueError(f"the {law.name} law has no integral variant (laws with one: {NNI_I.base.name}, "
                     f"{SNI2_I.base.name})")


#: The registered ``nni_i`` law.
NNI_I: IntegralLaw = register(IntegralLaw(NNI, NNIIntegralGains))  # type: ignore[assignment]
#: The registered ``sni2_i`` law.
SNI2_I: IntegralLaw = register(IntegralLaw(SNI2, SNI2IntegralGains))  # type: ignore[assignment]
