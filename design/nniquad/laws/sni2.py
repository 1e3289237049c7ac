"""The ``sni2`` law: the NNI structure with a second-order strictly negative-imaginary (SNI) controller.

Per axis the law is the NNI law's structure with a second-order SNI controller in
place of the integral resonant controller (same conventions: nominal mass
``m̂``, controller output a force ``z`` [N], positive feedback):

.. math:: a_h = -k_p ξ + z/\\hat m, \\qquad C(s) = \\frac{z}{ξ} = \\frac{k}{s^2 + 2ζω s + ω^2},

realised with the state ``(z, z')`` [N, N/s]:

.. math:: A_c = \\begin{bmatrix} 0 & 1 \\\\ -ω^2 & -2ζω \\end{bmatrix},\\quad
          B_c = \\begin{bmatrix} 0 \\\\ k \\end{bmatrix},\\quad C_c = [1\\ 0],\\quad D_c = 0.

Why it is strictly negative imaginary: for ``ω > 0``, ``Im C(jν) = -2ζων k/|ω² - ν² + 2jζων|² < 0``
on ``ν ∈ (0, ∞)`` exactly when ``k > 0`` and ``ζ > 0``, and its poles are in the open
left half plane; the phase of ``C(jν)`` runs in ``(-π, 0)``.  The project certifies it
with the NI lemma LMI (:mod:`nniquad.analysis.lmi.ni`), not with this remark.

DC (sector) condition of the NI stability theorem (Lanzon & Petersen 2008, recalled):
with the reshaped plant ``P(s) = 1/(m (s² + k_p))`` (lossless NI, ``P(0) = 1/(m k_p)``) the
positive-feedback loop is stable when ``P(0) C(0) < 1``, i.e.

.. math:: γ = \\frac{k}{\\hat m k_p ω^2} < 1,

and the paper's class asks ``γ <= γ_max`` (:func:`dc_loop_gain`).  For this loop the
condition is also necessary: the characteristic polynomial
``s⁴ + 2ζω s³ + (ω² + k_p) s² + 2ζω k_p s + k_p ω² (1 - γ)`` has the Routh entries
``2ζω³`` and ``4ζ²ω⁴ k_p γ`` besides its coefficients, so it is Hurwitz iff ``γ < 1``.

The NNI law is a limit of the family: for ``ζ >= 1`` the law of :func:`sni2_from_nni` is the
NNI controller ``Γ/(s + Γδ)`` followed by a low-pass ``1/(1 + s/p_2)`` with ``p_2 = ω²/(Γδ)``,
and ``p_2 → ∞`` as ``ζ → ∞``; so the filtered PD, which is an NNI law
(:mod:`nniquad.laws.pd_filtered`), is a limit of it too.

Start state: at take-over the controller starts at rest at its DC value for the measured position,
``z(0) = C(0) ξ(0) = (k/ω²) ξ(0)``, ``z'(0) = 0`` (:func:`start_state`): the command then starts at
``-k_p (1 - γ) ξ(0)``, the static stiffness, as the filtered PD starts its filter at the measured
position (``d(0) = ξ(0)``, no derivative kick).  Started at ``z = 0`` instead, the command starts
at ``-k_p ξ(0)``, the law's high-frequency gain: on the paper's vehicle the NNI image of the tuned
filtered PD, the same law started at ``z = 0``, fails the robust tuning scenarios that the PD passes
(``docs/notes/laws.md``).  The simulator, the tuner, the Monte Carlo study, the certificate's regions of
attraction and ``nniquad export`` all start the ``sni2`` law there.

The exact zero-order-hold equivalent of ``C(s)`` over a period ``T`` is written once in
closed form (:func:`zoh_entries`), for numbers and for CasADi expressions (the
simulator's discrete variant); ``nniquad export`` discretises the same matrices with
``scipy.linalg.expm`` instead (:meth:`nniquad.laws.base.ControlLaw.zoh`), and the tests compare the two.

Tuning coordinates (before the attitude loop's 3): ``ln kp``, the sector coordinate of the
class (``u = ln(γ_max/γ)`` or ``v = ln(1/γ - 1)``, :mod:`nniquad.laws.search_ranges`), ``ln ω``
and ``ln ζ``.  The box keeps ``ω <= π f_s`` (the resonance below the Nyquist frequency of the
sampled position) and ``ζ`` in :data:`SNI2_ZETA_RANGE`, whose top keeps the faster real pole
``ω (ζ + sqrt(ζ² - 1))`` inside the RK4 step's stability region; at ``ζ = 4`` the law is the NNI
law followed by a low-pass 62 times faster than its pole (:func:`sni2_from_nni`): the seeds from
NNI and filtered-PD designs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from nniquad.laws.base import GainBlock, NILaw, PlainGainBlock, TuningBox, gain_field, positive_gain
from nniquad.laws.nni import Gains
from nniquad.laws.registry import register
from nniquad.laws.search_ranges import KP_RANGE, sector_coordinate_range

__all__ = ["realisation", "controller_matrices", "dc_loop_gain", "dc_gain", "start_state", "start_direction",
           "zoh_entries", "controller_poles", "sni2_from_nni", "STATE_UNITS", "SNI2Gains", "SNI2Law", "SNI2",
           "SNI2_OMEGA_MIN", "SNI2_ZETA_RANGE", "sni2_omega_max"]

#: Units of the controller state (z, z') of one axis.
STATE_UNITS: tuple[str, str] = ("N", "N/s")


def realisation(k: Any, omega: Any, zeta: Any) -> tuple[list[list[Any]], list[list[Any]], list[list[Any]]]:
    """``(A_c, B_c, C_c)`` of one axis as nested lists of the entries (numbers or CasADi expressions).

    The one place the realisation is written; :func:`controller_matrices` makes arrays of it and the
    simulator (:mod:`nniquad.sim.models`) builds its state equation from the same entries.
    """
    return ([[0, 1], [-omega * omega, -2 * zeta * omega]], [[0], [k]], [[1, 0]])


def controller_matrices(k: float, omega: float, zeta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Numeric ``(A_c, B_c, C_c, D_c)`` of one axis (:func:`realisation`; ``D_c = 0``)."""
    A, B, C = (np.array(M, dtype=float) for M in realisation(k, omega, zeta))
    return A, B, C, np.zeros((1, 1))


def dc_loop_gain(m_hat: float, kp: float, k: float, omega: float) -> float:
    """``P(0) C(0) = k/(m̂ k_p ω²)``: the DC loop gain γ of the NI theorem (stable iff ``< 1``)."""
    return float(k) / (float(m_hat) * float(kp) * float(omega) ** 2)


def dc_gain(k: Any, omega: Any) -> Any:
    """``C(0) = k/ω²`` [N/m] (numbers or CasADi expressions)."""
    return k / (omega * omega)


def start_state(k: float, omega: float, xi0: Any) -> tuple[float, float, float, float]:
    """The controller state at take-over, both axes, ``(z_x, z_y, z'_x, z'_y) = (C(0) ξ_x, C(0) ξ_y, 0, 0)``.

    Parameters
    ----------
    k, omega
        Controller gain [N/(m s²)] and natural frequency [rad/s].
    xi0
        The position measured at take-over [m] (north, east).
    """
    c0 = dc_gain(float(k), float(omega))
    return (c0 * float(xi0[0]), c0 * float(xi0[1]), 0.0, 0.0)


def start_direction(k: float, omega: float) -> "np.ndarray":
    """The start state of one axis per metre of displacement from rest: ``(ξ, ξ', z, z') = (1, 0, C(0), 0)``."""
    return np.array([1.0, 0.0, dc_gain(float(k), float(omega)), 0.0])


def controller_poles(omega: float, zeta: float) -> tuple[complex, complex]:
    """The two poles of ``C(s)``: ``-ζω ± ω sqrt(ζ² - 1)`` [1/s]."""
    root = complex(zeta * zeta - 1.0) ** 0.5
    return (-zeta * omega + omega * root, -zeta * omega - omega * root)


def _entire(x: Any, lib: Any) -> tuple[Any, Any]:
    """``(cosh √x, sinh √x / √x)`` for real ``x`` of either sign (``cos``/``sin`` for ``x < 0``; 1 at ``x = 0``).

    ``lib`` is :mod:`math`-like (``numpy`` or ``casadi``); both branches are formed from ``|x|`` so that
    neither is undefined, and the ratio is taken from a series where ``|x|`` is tiny.
    """
    r = lib.sqrt(lib.fabs(x))
    tiny = 1e-8
    safe_r = lib.fmax(r, tiny)
    ch_pos, sh_pos = lib.cosh(r), lib.sinh(safe_r) / safe_r
    ch_neg, sh_neg = lib.cos(r), lib.sin(safe_r) / safe_r
    series = 1.0 + x / 6.0
    ch = _where(x >= 0, ch_pos, ch_neg, lib)
    sh = _where(r < tiny, series, _where(x >= 0, sh_pos, sh_neg, lib), lib)
    return ch, sh


def _where(cond: Any, a: Any, b: Any, lib: Any) -> Any:
    if lib is np:
        return np.where(cond, a, b)
    return lib.if_else(cond, a, b)


def zoh_entries(k: Any, omega: Any, zeta: Any, T: Any, lib: Any = np) -> tuple[list[list[Any]], list[list[Any]]]:
    """Exact ZOH of one axis over ``T`` in closed form: ``(A_d, B_d)`` as nested lists of entries.

    With ``σ = ζω`` and ``ν² = σ² - ω²`` (``(A_c + σI)² = ν² I``),
    ``e^{A_c T} = e^{-σT} [cosh(νT) I + sinh(νT)/ν (A_c + σI)]`` (``cos``/``sin`` of ``|ν|T`` when the
    poles are complex), and since ``A_c`` is invertible ``B_d = A_c^{-1}(e^{A_c T} - I) B_c``, whose
    entries are ``k (1 - E_11)/ω²`` and ``k E_12``.  ``1 - E_11 ≈ (ωT)²/2`` is formed by a
    difference, so ``B_d[0]`` carries a relative rounding error of about ``2 ε/(ωT)²`` (1e-11 at
    the tuner's smallest ``ωT = 0.005``), far below what the closed loop resolves.

    Parameters
    ----------
    k, omega, zeta
        Controller gain [N/(m s²)], natural frequency [rad/s], damping ratio.
    T
        Sample period [s].
    lib
        ``numpy`` (numbers) or ``casadi`` (expressions).
    """
    sigma = zeta * omega
    ch, sh = _entire((sigma * sigma - omega * omega) * T * T, lib)
    decay = lib.exp(-sigma * T)
    s_t = decay * T * sh
    e11, e12 = decay * ch + sigma * s_t, s_t
    e21, e22 = -omega * omega * s_t, decay * ch - sigma * s_t
    return [[e11, e12], [e21, e22]], [[k * (1.0 - e11) / (omega * omega)], [k * e12]]


def sni2_from_nni(kp: float, Gamma: float, delta: float, zeta: float) -> tuple[float, float, float, float]:
    """The second-order law ``(kp, k, ω, ζ)`` that is the NNI law ``(kp, Γ, δ)`` followed by a low-pass.

    With ``ζ >= 1`` the poles are real, ``-p_1`` and ``-p_2`` with ``p_1 p_2 = ω²``; choosing
    ``p_1 = Γδ`` (``ω = Γδ (ζ + sqrt(ζ² - 1))``) and ``k = ω²/δ`` gives exactly

    .. math:: C(s) = \\frac{Γ}{s + Γδ} \\cdot \\frac{1}{1 + s/p_2}, \\qquad p_2 = ω^2/(Γδ),

    the NNI controller and a first-order low-pass at ``p_2``.  The DC gain ``k/ω² = 1/δ`` and so
    the DC loop gain ``γ = 1/(m k_p δ)`` are the NNI law's; as ``ζ → ∞``, ``p_2 → ∞`` and the law
    tends to the NNI law (``ζ = 3`` puts ``p_2`` at 34 Γδ, ``ζ = 5`` at 98 Γδ).

    Parameters
    ----------
    kp, Gamma, delta
        The NNI gains.
    zeta
        Damping ratio of the image, ``>= 1``.

    Raises
    ------
    ValueError
        ``zeta < 1`` (the image of this construction has real poles).
    """
    if not zeta >= 1.0:
        raise ValueError(f"the NNI image needs zeta >= 1 (real poles), got {zeta!r}")
    omega = Gamma * delta * (zeta + math.sqrt(zeta * zeta - 1.0))
    return float(kp), float(omega * omega / delta), float(omega), float(zeta)


@dataclass(frozen=True)
class SNI2Gains(PlainGainBlock):
    """The NNI structure with a second-order strictly negative-imaginary controller (``controller = "sni2"``).

    Per axis ``a_h = -k_p ξ_m + z/m̂`` with ``z = C(s) ξ_m``, ``C(s) = k/(s² + 2ζω s + ω²)``
    (module docstring: the realisation, the DC condition ``k/(m̂ k_p ω²) < 1`` and the exact
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

    kp: float = gain_field("1/s^2", "inner-loop gain")
    k: float = gain_field("N/(m s^2)", "gain of the SNI controller C(s) = k/(s^2 + 2 zeta omega s + omega^2)")
    omega: float = gain_field("rad/s", "natural frequency of C(s)", "ω")
    zeta: float = gain_field("-", "damping ratio of C(s)", "ζ")

    def dc_loop_gain(self, m_hat: float) -> float:
        """``k/(m̂ k_p ω²)``, the DC loop gain γ of the NI theorem (:func:`dc_loop_gain`).

        Parameters
        ----------
        m_hat
            The mass [kg].
        """
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


#: Smallest natural frequency ω of the ``sni2`` controller searched [rad/s].
SNI2_OMEGA_MIN: float = 0.5
#: Damping ratio ζ of the ``sni2`` controller searched: from a resonance (0.1) to real poles 62 : 1 apart (4).
SNI2_ZETA_RANGE: tuple[float, float] = (0.1, 4.0)


def sni2_omega_max(pole_max: float, rk4_pole_max: float) -> float:
    """Largest ω of the ``sni2`` box [rad/s]: the controller pole bound (``π f_s`` and the RK4 limit), and the faster
    real pole ``ω (ζ + sqrt(ζ² - 1))`` at the top of :data:`SNI2_ZETA_RANGE` inside the RK4 limit.

    Parameters
    ----------
    pole_max
        The largest controller pole [1/s] (:func:`nniquad.tuning.vehicle_limits.gain_limits`).
    rk4_pole_max
        Largest pole the RK4 step integrates, ``config.RK4_STEP_LIMIT / dt`` [1/s].
    """
    z = SNI2_ZETA_RANGE[1]
    return min(pole_max, rk4_pole_max / (z + math.sqrt(z * z - 1.0)))


class SNI2Law(NILaw):
    """The ``sni2`` law (module docstring)."""

    name: ClassVar[str] = "sni2"
    title: ClassVar[str] = "velocity-free, second-order SNI controller k/(s^2 + 2 zeta omega s + omega^2)"
    gains_type: ClassVar[type] = SNI2Gains
    state_names: ClassVar[tuple[str, ...]] = ("zc", "zcd")
    state_units: ClassVar[tuple[str, ...]] = STATE_UNITS
    time_scaling: ClassVar[Mapping[str, int]] = {"kp": 2, "k": 4, "omega": 1, "zeta": 0}
    pole_label: ClassVar[str] = "SNI controller (omega, zeta)"
    pole_hint: ClassVar[str] = "omega or zeta, or SimOptions.dt_s"
    gamma_formula: ClassVar[str] = "k/(m kp omega^2)"
    controller_label: ClassVar[str] = "second-order SNI controller"
    display_name: ClassVar[str] = "second-order SNI (sni2)"
    start_description: ClassVar[str] = ("controller state at rest at its DC value C(0) times the position (the sni2 "
                                        "law's take-over state)")
    #: The robust objective's budgets: ``normal`` is the ``thorough`` search without its extra seeds (five seeds of
    #: the default ``normal`` spread 27.7 % on the paper's vehicle, five of this one 1.1 %: ``docs/notes/tuning.md``).
    robust_budget_overrides: ClassVar[Mapping[str, tuple[str, int | None]]] = {"normal": ("thorough", 0)}

    def controller_realisation(self, p: Mapping[str, Any]) -> tuple[list, list, list, list]:
        A, B, C = realisation(p["k"], p["omega"], p["zeta"])
        return A, B, C, [[0.0]]

    def dc_gain(self, gains: SNI2Gains) -> float:
        return dc_gain(gains.k, gains.omega)

    def dc_loop_gain(self, gains: SNI2Gains, m: float, kp: float) -> float:
        """``k/(m kp ω²)`` of one axis with inner gain ``kp``.

        Parameters
        ----------
        gains
            ``sni2`` gains.
        m
            The mass of the reduced loop [kg].
        kp
            The (effective) inner gain [1/s²].
        """
        return dc_loop_gain(m, kp, gains.k, gains.omega)

    def sector_constant(self, gains: SNI2Gains, m: float) -> float:
        return self.dc_loop_gain(gains, m, gains.kp)

    def sector_limit(self, gains: SNI2Gains, m: float, kp: float, gamma: float) -> tuple[str, float]:
        return "k_max", float(gamma) * float(m) * float(kp) * gains.omega ** 2

    def sector_violation(self, gains: SNI2Gains, m: float, gamma_max: float) -> str:
        _, limit = self.sector_limit(gains, m, gains.kp, gamma_max)
        gamma = self.sector_constant(gains, m)
        return (f"k = {gains.k:.6g} > gamma_max m kp omega^2 = {limit:.6g} (DC loop gain k/(m kp omega^2) = "
                f"{gamma:.6g} > gamma_max {gamma_max:g})")

    def start_state(self, gains: SNI2Gains, m_hat: float, xi0: Sequence[float]) -> np.ndarray:
        return np.array(start_state(gains.k, gains.omega, xi0))

    def zoh_entries(self, p: Mapping[str, Any], T: Any, lib: Any, axis: int = 0) -> tuple[list, list]:
        return zoh_entries(p["k"], p["omega"], p["zeta"], T, lib)

    def discretisation_text(self) -> str:
        return ("exact zero-order hold of C(s) = k/(s^2 + 2 zeta omega s + omega^2), realised per axis as "
                "(z, z')' = [[0, 1], [-omega^2, -2 zeta omega]] (z, z') + [0, k] xi (scipy.linalg.expm); state order "
                "(z_x, z_y, z'_x, z'_y)")

    def export_matrix_units(self) -> dict[str, str]:
        return {"A": "- (z rows/columns), 1/s or s across", "B": "N/m (z), N/(m s) (z')", "C": "1/kg",
                "D": "1/s^2"}

    def fastest_pole(self, gains: SNI2Gains, m_hat: float = 1.0) -> float:
        return max(abs(pole) for pole in controller_poles(gains.omega, gains.zeta))

    def controller_scaling(self, gains: SNI2Gains) -> np.ndarray:
        """``diag(C(0), k/ω)``: ``z`` in units of ``C(0) = k/ω²`` per metre, ``z'`` in units of ``k/ω`` (the
        realisation ``(T⁻¹A_cT, T⁻¹B_c, C_cT)`` is then of order ω and 1).

        Parameters
        ----------
        gains
            ``sni2`` gains.
        """
        return np.diag([gains.k / gains.omega**2, gains.k / gains.omega])

    def controller_normalisation(self, gains: SNI2Gains) -> tuple[np.ndarray, float]:
        """``(T, ω)``: :meth:`controller_scaling` and the time in units of ``1/ω``, in which the controller is
        ``[[0, 1], [-1, -2ζ]]``, ``[0, 1]``, ``[C(0), 0]`` and every term of the NI dissipation matrix is of
        order ``C(0)``.

        Parameters
        ----------
        gains
            ``sni2`` gains.
        """
        return self.controller_scaling(gains), float(gains.omega)

    def axis_scaling(self, gains: SNI2Gains, kp: float, m_nominal: float) -> np.ndarray:
        """Position in m, velocity in units of ``sqrt(k_p)``, ``z`` in units of ``m k_p`` (``z/m`` balances
        ``k_p ξ``), ``z'`` in units of ``m k_p ω``.

        Parameters
        ----------
        gains
            ``sni2`` gains.
        kp
            The axis's inner gain [1/s²].
        m_nominal
            The nominal mass [kg].
        """
        mk = m_nominal * kp
        return np.diag([1.0, np.sqrt(kp), mk, mk * gains.omega])

    # ------------------------------------------------------------------ tuning
    def coordinates(self, law_class: str | None) -> tuple[str, ...]:
        q1 = ("u = ln(gamma_max/gamma), gamma = k/(m kp omega^2)" if self.check_class(law_class) == "paper"
              else "v = ln(1/gamma - 1), gamma = k/(m kp omega^2)")
        return ("ln kp", q1, "ln omega", "ln zeta")

    def box(self, law_class: str | None, limits: TuningBox) -> tuple[list[float], list[float]]:
        q1 = sector_coordinate_range(self.check_class(law_class))
        w_max = sni2_omega_max(limits.pole_max, limits.rk4_pole_max)
        return ([math.log(KP_RANGE[0]), q1[0], math.log(SNI2_OMEGA_MIN), math.log(SNI2_ZETA_RANGE[0])],
                [math.log(limits.kp_max), q1[1], math.log(w_max), math.log(SNI2_ZETA_RANGE[1])])

    def decode(self, q: Sequence[float], m: float, gamma_max: float, law_class: str | None) -> SNI2Gains:
        kp = math.exp(q[0])
        paper = self.check_class(law_class) == "paper"
        gamma = gamma_max * math.exp(-q[1]) if paper else 1.0 / (1.0 + math.exp(q[1]))
        omega = math.exp(q[2])
        return SNI2Gains(kp=kp, k=gamma * m * kp * omega**2, omega=omega, zeta=math.exp(q[3]))

    def encode(self, gains: Any, m: float, gamma_max: float, law_class: str | None) -> list[float]:
        if not isinstance(gains, SNI2Gains):
            raise ValueError(f"{type(gains).__name__} is not a gain block of the {self.name!r} law")
        gamma = gains.dc_loop_gain(m)
        if self.check_class(law_class) == "paper":
            q1 = math.log(gamma_max / gamma)
        elif gamma < 1.0:
            q1 = math.log(1.0 / gamma - 1.0)
        else:
            raise ValueError(f"DC loop gain {gamma:.6g} >= 1: outside the cascade class's coordinates")
        return [math.log(gains.kp), q1, math.log(gains.omega), math.log(gains.zeta)]

    def sector_face(self, law_class: str | None) -> bool:
        return self.check_class(law_class) == "paper"

    def seed_from(self, gains: GainBlock, m_hat: float) -> SNI2Gains | None:
        """Another law's design as an ``sni2`` design: its NNI image followed by a low-pass at the top of
        :data:`SNI2_ZETA_RANGE` (:func:`sni2_from_nni`).

        Parameters
        ----------
        gains
            A gain block of any law.
        m_hat
            The controller's nominal mass [kg].
        """
        image = self.image_of(gains, m_hat)
        if isinstance(image, Gains):  # the NNI law followed by a fast low-pass (real poles 62 : 1 apart)
            image = SNI2Gains(*sni2_from_nni(image.kp, image.Gamma, image.delta, SNI2_ZETA_RANGE[1]))
        return image if isinstance(image, SNI2Gains) else None


#: The registered ``sni2`` law.
SNI2 = register(SNI2Law())
