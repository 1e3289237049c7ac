"""Loop algebra on plain matrices: closed loops with break points, loop transfer functions, Padé delays.

:mod:`nniquad.analysis.linearised_cascade` derives the cascade's matrices from the
simulator; this module holds what is done with them once they are numbers:

* :class:`ClosedLoop`: a continuous-time closed loop ``x' = A x`` and its break
  points ``(b, c)`` (``A = A_0 + b c``);
* :class:`LinearSystem`: a system ``G = C (sI - A)⁻¹ B + D`` (continuous, or
  discrete with period ``dt``) as four matrices: the loop transfer function at
  a break point, or the reduced loop's plant and controller.  What the margins
  and the frequency-domain NI checks need from it (poles, frequency response,
  DC gain, the positive-feedback interconnection) is numpy, evaluated as
  python-control evaluates a ``StateSpace`` (the tests compare them), and
  :meth:`LinearSystem.to_control` gives the python-control ``StateSpace`` for
  anyone who wants one;
* :func:`pade_delay`: a state-space realisation of the Padé approximant of a
  delay ``e^{-sτ}``.

Nothing here imports python-control unless a ``StateSpace`` is asked for: a
cold ``nniquad verify`` or ``nniquad lmi`` runs without it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nniquad.errors import CascadeError

__all__ = ["LinearSystem", "as_linear_system", "feedback_matrix", "ClosedLoop", "pade_coefficients", "pade_delay"]


@dataclass(frozen=True)
class LinearSystem:
    """A linear system ``G = C (sI - A)⁻¹ B + D`` (``z`` instead of ``s`` when ``dt`` is set).

    Attributes
    ----------
    A, B, C, D : ndarray
        ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``.
    dt
        Sample period [s]; ``None`` for continuous time.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt: float | None = None

    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (python-control's ``StateSpace.poles`` definition)."""
        return np.linalg.eigvals(self.A).astype(complex)

    def evaluate(self, x: np.ndarray) -> np.ndarray:
        """``G(x)`` at complex points ``x`` (``s``, or ``z`` in discrete time), shape ``(p, m, len(x))``.

        One linear solve per point, ``C (xI - A)⁻¹ B + D``, as python-control's
        ``StateSpace.horner`` does without slycot (a one-state system by its
        closed form ``C/(x - a) B + D``); at a pole the value is ``inf + nan j``.
        """
        x = np.atleast_1d(np.asarray(x)).astype(complex)
        A, B, C, D = self.A, self.B, self.C, self.D
        n = A.shape[0]
        if n == 1:
            with np.errstate(divide="ignore", invalid="ignore"):
                return C[:, :, None] / (x - A[0, 0]) * B[:, :, None] + D[:, :, None]
        out = np.empty((C.shape[0], B.shape[1], x.size), dtype=complex)
        for k, xk in enumerate(x):
            try:
                out[:, :, k] = C @ np.linalg.solve(xk * np.eye(n) - A, B) + D
            except np.linalg.LinAlgError:  # x is a pole
                out[:, :, k] = complex(np.inf, np.nan)
        return out

    def frequency_response(self, omega: np.ndarray) -> np.ndarray:
        """``G(jω)`` (continuous) or ``G(e^{jωT})`` (discrete) at frequencies ``omega`` [rad/s], ``(p, m, len(ω))``."""
        w = np.atleast_1d(np.asarray(omega, float))
        return self.evaluate(np.exp(1j * w * self.dt) if self.dt else 1j * w)

    def dc_gain(self) -> np.ndarray:
        """``G(0)`` (continuous) or ``G(1)`` (discrete), real when its imaginary part is zero, ``(p, m)``."""
        g = self.evaluate(np.array([1.0 if self.dt else 0.0]))[:, :, 0]
        return g.real if np.all(g.imag == 0) else g

    def to_control(self):
        """The same system as a python-control ``StateSpace``."""
        import control as ct

        return ct.ss(self.A, self.B, self.C, self.D, 0 if self.dt is None else self.dt)


def as_linear_system(sys) -> LinearSystem:
    """A :class:`LinearSystem` from one, from any object with ``A, B, C, D`` (a python-control
    ``StateSpace``), or from a python-control ``TransferFunction`` (realised by python-control).

    Parameters
    ----------
    sys
        The system.
    """
    if isinstance(sys, LinearSystem):
        return sys
    if not all(hasattr(sys, k) for k in ("A", "B", "C", "D")):
        import control as ct

        sys = ct.ss(sys)
    dt = getattr(sys, "dt", None)
    return LinearSystem(*(np.atleast_2d(np.asarray(getattr(sys, k), dtype=float)) for k in ("A", "B", "C", "D")),
                        dt=None if dt in (0, None, True) else float(dt))


def feedback_matrix(G: LinearSystem, K: LinearSystem, sign: float = -1.0) -> np.ndarray:
    """State matrix of the feedback interconnection ``u_G = r + sign * y_K``, ``u_K = y_G``.

    States ``[x_G, x_K]``; with ``E = (I - sign D_K D_G)⁻¹`` (the algebraic loop),
    ``A = [[A_G + sign B_G E D_K C_G, sign B_G E C_K], [B_K (I + sign D_G E D_K) C_G, A_K + sign B_K D_G E C_K]]``,
    python-control's ``feedback(G, K, sign)``.

    Parameters
    ----------
    G, K
        Forward and feedback systems (``K``'s input is ``G``'s output and back).
    sign
        ``-1`` negative, ``+1`` positive feedback.
    """
    s = float(sign)
    E = np.linalg.solve(np.eye(G.D.shape[1]) - s * K.D @ G.D, np.eye(G.D.shape[1]))
    T = np.eye(G.D.shape[0]) + s * G.D @ E @ K.D
    return np.block([[G.A + s * G.B @ E @ K.D @ G.C, s * G.B @ E @ K.C],
                     [K.B @ T @ G.C, K.A + s * K.B @ G.D @ E @ K.C]])


@dataclass(frozen=True)
class ClosedLoop:
    """A continuous-time closed loop with its break-point signals.

    ``x' = A x``; a break point is a scalar signal ``v = c x`` the loop feeds
    back into itself through ``b`` (``A = A_0 + b c``).  The loop transfer
    function in the negative-feedback convention is
    ``L(s) = -c (sI - A_0)^{-1} b`` (the closed loop is ``1 + L = 0``).

    Attributes
    ----------
    A : ndarray (n, n)
        Closed-loop matrix [1/s].
    state_names
        Names of the states.
    breaks : dict
        ``name -> (b, c)`` of each break point.
    """

    A: np.ndarray
    state_names: tuple[str, ...]
    breaks: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` [1/s], slowest (largest real part) first."""
        ev = np.linalg.eigvals(self.A)
        return ev[np.argsort(-ev.real, kind="stable")]

    def loop_system(self, name: str) -> LinearSystem:
        """The loop transfer function at a break point, as a :class:`LinearSystem`.

        Parameters
        ----------
        name
            One of :attr:`breaks` (``"horizontal"``, ``"attitude"``).
        """
        if name not in self.breaks:
            raise CascadeError(f"unknown break point {name!r} (choose one of {', '.join(self.breaks)})")
        b, c = self.breaks[name]
        return LinearSystem(self.A - np.outer(b, c), b.reshape(-1, 1), -c.reshape(1, -1), np.zeros((1, 1)))

    def loop(self, name: str):
        """The loop transfer function at a break point, as a python-control ``StateSpace``.

        Parameters
        ----------
        name
            One of :attr:`breaks` (``"horizontal"``, ``"attitude"``).
        """
        return self.loop_system(name).to_control()


def pade_coefficients(delay: float, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator (descending powers of ``s``, monic denominator) of the Padé ``[n/n]`` of ``e^{-s τ}``.

    ``e^{-sτ} ≈ Σ c_k (-sτ)^k / Σ c_k (sτ)^k`` with
    ``c_k = (2n - k)! n! / ((2n)! k! (n - k)!)`` (Golub & Van Loan, *Matrix
    Computations*, the diagonal Padé approximant of the exponential).

    Parameters
    ----------
    delay
        ``τ`` [s], positive.
    order
        ``n >= 1``.
    """
    n = int(order)
    if not (math.isfinite(delay) and delay > 0 and n >= 1):
        raise CascadeError(f"a Padé delay needs a positive delay and order >= 1, got {delay!r}, {order!r}")
    c = [math.factorial(2 * n - k) * math.factorial(n) / (math.factorial(2 * n) * math.factorial(k)
                                                          * math.factorial(n - k)) for k in range(n + 1)]
    lead = c[n] * delay ** n
    num = np.array([c[k] * (-delay) ** k for k in range(n, -1, -1)]) / lead
    den = np.array([c[k] * delay ** k for k in range(n, -1, -1)]) / lead
    return num, den


def pade_delay(delay: float, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` of the Padé approximant of ``e^{-s τ}`` in controllable canonical form.

    The companion form ``A`` (first row ``-a_1 … -a_n``, ones below the diagonal),
    ``B = e_1``, ``D = b_0`` and ``C = b_{1:} - b_0 a_{1:}``, for the monic
    denominator ``a`` and numerator ``b`` of :func:`pade_coefficients` (the
    realisation python-control builds from the same transfer function; the tests
    compare them).

    Parameters
    ----------
    delay
        ``τ`` [s], positive.
    order
        ``n >= 1``.
    """
    num, den = pade_coefficients(delay, order)
    n = den.size - 1
    A = np.zeros((n, n))
    A[0] = -den[1:]
    A[1:, :-1] += np.eye(n - 1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    C = (num[1:] - num[0] * den[1:]).reshape(1, n)
    D = np.array([[num[0]]])
    return A, B, C, D
