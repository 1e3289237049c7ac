"""The second-order strictly negative-imaginary (SNI) controller: realisation, DC gain and exact ZOH, written once.

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
(:mod:`nniquad.control.pd_equivalence`), is a limit of it too.

Start state: at take-over the controller starts at rest at its DC value for the measured position,
``z(0) = C(0) ξ(0) = (k/ω²) ξ(0)``, ``z'(0) = 0`` (:func:`start_state`): the command then starts at
``-k_p (1 - γ) ξ(0)``, the static stiffness, as the filtered PD starts its filter at the measured
position (``d(0) = ξ(0)``, no derivative kick).  Started at ``z = 0`` instead, the command starts
at ``-k_p ξ(0)``, the law's high-frequency gain: on the paper's vehicle the NNI image of the tuned
filtered PD, the same law started at ``z = 0``, fails the robust tuning scenarios that the PD passes
(FINDINGS.md).  The simulator, the tuner, the Monte Carlo study, the certificate's regions of
attraction and ``nniquad export`` all start the ``sni2`` law there.

The exact zero-order-hold equivalent of ``C(s)`` over a period ``T`` is written once in
closed form (:func:`zoh_entries`), for numbers and for CasADi expressions (the
simulator's discrete variant); ``nniquad export`` discretises the same matrices with
``scipy.linalg.expm`` instead (:mod:`nniquad.control.discrete`), and the tests compare the two.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["realisation", "controller_matrices", "dc_loop_gain", "dc_gain", "start_state", "start_direction",
           "zoh_entries", "controller_poles", "sni2_from_nni", "STATE_UNITS"]

#: Units of the controller state (z, z') of one axis.
STATE_UNITS: tuple[str, str] = ("N", "N/s")


def realisation(k: Any, omega: Any, zeta: Any) -> tuple[list[list[Any]], list[list[Any]], list[list[Any]]]:
    """``(A_c, B_c, C_c)`` of one axis as nested lists of the entries (numbers or CasADi expressions).

    The one place the realisation is written; :func:`controller_matrices` makes arrays of it and the
    simulator (:mod:`nniquad.sim.models`) builds its state equation from the same entries.
    """
    return ([[0.0, 1.0], [-omega * omega, -2.0 * zeta * omega]], [[0.0], [k]], [[1.0, 0.0]])


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
