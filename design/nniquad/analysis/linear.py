"""Reduced horizontal loop: state space, characteristic polynomial, Routh region, sector bound.

The paper (Ghallab & Petersen, Section "Control design") reshapes each horizontal
axis by the inner proportional loop into

.. math:: m \\ddot\\xi + m k_p \\xi = F_h, \\qquad y = \\xi

(eq. ``compact_horizontal``), and closes the outer loop with the integral
resonant controller :math:`C(s) = (s + \\Gamma\\delta)^{-1}\\Gamma` (eq.
``SNI_controller``, realisation ``controller_state_space``: :math:`\\dot z =
-\\Gamma\\delta z + \\Gamma \\xi`, :math:`u_c = z`) in **positive** feedback,
:math:`F_h = u_c`.  The axes are decoupled, so everything is per axis; the two
axes differ only through :math:`k_p^x, k_p^y`.

One source of truth
-------------------
The plant and controller matrices are written **once**, symbolically, in
:func:`plant_matrices_sym` and :func:`controller_matrices_sym`.  The closed loop
is *built* from them by the positive-feedback interconnection formula
(:func:`closed_loop_matrix_sym`), never retyped; numeric matrices come from
``sympy.lambdify`` of those expressions.  State per axis: ``[xi, xi_dot, z]``
(position in m, velocity in m/s, controller state in N).

What the symbolic layer derives (and the tests check against hand algebra):

* characteristic polynomial :math:`s^3 + \\Gamma\\delta s^2 + k_p s +
  \\Gamma(k_p\\delta - 1/m)`;
* Routh-Hurwitz: stable iff :math:`m k_p \\delta > 1` (the other Routh entry,
  :math:`\\Gamma/m`, is positive for positive data);
* the DC loop gain :math:`G(0)C(0) = 1/(m k_p \\delta)`, so the paper's sector
  bound :math:`\\delta^2 \\ge 1/(\\gamma^2 m^2 \\min k_p^2)` is
  :math:`G(0)C(0) \\le \\gamma` and the smallest admissible γ is the DC loop
  gain itself.  The union over γ ∈ (0, 1) of the sector regions is exactly the
  Routh region: for this loop the sector condition is not only sufficient but
  also necessary for stability.

Mass uncertainty follows the paper's model: the true mass ``m`` enters only
through the input matrix ``1/m`` (the inner loop's ``k_p`` is an acceleration
gain), so a closed loop with true mass ``m`` is :func:`closed_loop_A_axis` at
``m``; the controller does not contain ``m`` at all (the nominal mass only enters
the *choice* of δ through the sector bound).

Numeric layer
-------------
:class:`ReducedLoop` holds one vehicle mass and one :class:`~nniquad.control.gains.Gains`
block; every numeric quantity (matrices, python-control models, Routh verdict,
sector bound, poles) is a method or property of it, evaluated by the lambdified
symbolic expressions.  ``ReducedLoop(m, gains, m_nominal=m_hat)`` is the loop
whose thrust is sized with a nominal mass ``m_hat`` while the true mass is ``m``
(the model of :mod:`nniquad.sim`); :meth:`ReducedLoop.with_mass` builds
both true-mass models from a nominal loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nniquad import codecache
from nniquad.analysis.loops import LinearSystem
from nniquad.control.gains import PAPER_GAINS, Gains, positive_gain
from nniquad.errors import GainError
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle

#: The symbolic layer's names re-exported here; :mod:`nniquad.analysis.linear_symbolic` (sympy) is imported on
#: first use of one of them (PEP 562), so the numeric layer runs without sympy when its code is cached.
_SYMBOLIC_NAMES = ("SYMBOLS", "plant_matrices_sym", "controller_matrices_sym", "closed_loop_matrix_sym",
                   "characteristic_polynomial", "routh_array", "routh_stability_region", "dc_loop_gain_sym")


def __getattr__(name: str):
    if name in _SYMBOLIC_NAMES:
        from nniquad.analysis import linear_symbolic

        return getattr(linear_symbolic, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def lambdified() -> dict:
    """The numeric functions lambdified from the symbolic layer (:func:`nniquad.analysis.linear_symbolic.lambdified`).

    Their generated source is kept by :mod:`nniquad.codecache`; a process that
    finds it there does not import sympy.
    """
    def build() -> dict:
        from nniquad.analysis import linear_symbolic

        return linear_symbolic.lambdified()

    return codecache.cached_numpy_functions("nniquad.analysis.linear_symbolic.lambdified", build)

__all__ = [
    "SYMBOLS",
    "plant_matrices_sym",
    "controller_matrices_sym",
    "closed_loop_matrix_sym",
    "characteristic_polynomial",
    "routh_array",
    "routh_stability_region",
    "dc_loop_gain_sym",
    "ReducedLoop",
    "PAPER_LOOP",
    "PolesDamping",
]

# ----------------------------------------------------------------------------- numeric layer


def _f(array) -> np.ndarray:
    return np.array(array, dtype=float)


_AXES = ("x", "y")


@dataclass(frozen=True)
class PolesDamping:
    """Closed-loop poles of both axes with natural frequencies and damping ratios.

    Attributes
    ----------
    poles : complex ndarray
        Eigenvalues of :meth:`ReducedLoop.closed_loop_A` (1/s).
    wn : ndarray
        Natural frequencies (rad/s).
    zeta : ndarray
        Damping ratios (dimensionless).
    max_real_part : float
        Largest real part (1/s); the loop is stable iff it is negative.
    min_damping : float
        Smallest damping ratio among the poles.
    decay_rate : float
        ``-2 max Re(pole)``: the supremum of the ε for which
        ``A^T P + P A <= -eps P`` has a solution ``P > 0`` (1/s).
    """

    poles: np.ndarray
    wn: np.ndarray
    zeta: np.ndarray
    max_real_part: float
    min_damping: float
    decay_rate: float

    @property
    def stable(self) -> bool:
        """Whether every pole has a negative real part."""
        return self.max_real_part < 0.0


@dataclass(frozen=True)
class ReducedLoop:
    """The reduced horizontal closed loop of one vehicle mass and one gain set (both axes).

    Parameters
    ----------
    m
        The vehicle's (true) mass [kg].
    gains
        The NNI gain block (``kp``, ``Gamma``, ``delta`` and optionally ``kpy``).
    m_nominal
        ``None`` (default): the paper's reduced model, ``kp`` an exact acceleration
        gain.  A mass [kg]: the thrust is sized with this nominal mass, so the plant
        realises ``(m_nominal/m)`` times the commanded acceleration
        ``a = -kp xi + z/m_nominal`` (the model of :mod:`nniquad.sim`).
        The loop is then the paper's loop at mass ``m`` with the effective inner gain
        ``kp m_nominal / m``.
    g
        Gravitational acceleration [m/s^2]; only the saturation (tilt-limit) analysis
        uses it.  Default: the paper vehicle's.

    Raises
    ------
    GainError
        If ``m`` or ``m_nominal`` is not a finite positive number, or ``gains`` is not
        a :class:`~nniquad.control.gains.Gains`.
    """

    m: float
    gains: Gains
    m_nominal: float | None = None
    g: float = PAPER_VEHICLE.g

    def __post_init__(self) -> None:
        object.__setattr__(self, "m", positive_gain("m", self.m))
        if not isinstance(self.gains, Gains):
            raise GainError(f"a reduced loop needs a Gains block, got {type(self.gains).__name__}")
        if self.m_nominal is not None:
            object.__setattr__(self, "m_nominal", positive_gain("m_nominal", self.m_nominal))
        object.__setattr__(self, "g", positive_gain("g", self.g))

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_vehicle(cls, vehicle: Vehicle, gains: Gains) -> "ReducedLoop":
        """The paper-model loop of ``vehicle`` (its mass and gravity) with ``gains``.

        Parameters
        ----------
        vehicle
            The vehicle; only ``m`` and ``g`` enter the reduced loop.
        gains
            The NNI gain block.
        """
        return cls(vehicle.m, gains, g=vehicle.g)

    @property
    def nominal_mass(self) -> float:
        """The mass the controller is designed for (``m_nominal``, else ``m``) [kg]."""
        return self.m if self.m_nominal is None else self.m_nominal

    def with_mass(self, m_true: float, *, thrust_model: bool = False) -> "ReducedLoop":
        """The same controller on a vehicle whose true mass is ``m_true``.

        Parameters
        ----------
        m_true
            True mass [kg].
        thrust_model
            ``False``: the paper's reduced model (only ``z/m`` sees the true mass).
            ``True``: the thrust is sized with this loop's :attr:`nominal_mass`.
        """
        return ReducedLoop(m_true, self.gains, self.nominal_mass if thrust_model else None, self.g)

    def with_gains(self, gains: Gains) -> "ReducedLoop":
        """The same vehicle with another gain set.

        Parameters
        ----------
        gains
            The new NNI gain block.
        """
        return ReducedLoop(self.m, gains, self.m_nominal, self.g)

    # ------------------------------------------------------------------ gains per axis

    @property
    def Gamma(self) -> float:
        """Controller gain Γ."""
        return self.gains.Gamma

    @property
    def delta(self) -> float:
        """Controller parameter δ."""
        return self.gains.delta

    def kp(self, axis: str = "x") -> float:
        """The inner gain of an axis (``'x'`` or ``'y'``) as designed [1/s^2].

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        if axis not in _AXES:
            raise GainError(f"axis must be 'x' or 'y', got {axis!r}")
        return self.gains.kp if axis == "x" else self.gains.kp_y

    def _kp_eff(self, axis: str) -> float:
        """Inner gain the plant realises: ``kp`` (paper model) or ``kp m_nominal / m``."""
        kp = self.kp(axis)
        return kp if self.m_nominal is None else kp * self.m_nominal / self.m

    @property
    def axes(self) -> list[tuple[str, float]]:
        """``[('x', kpx)]`` when both axes share ``kp``, else ``[('x', kpx), ('y', kpy)]``."""
        kpx, kpy = self.gains.axes()
        return [("x", kpx)] if kpx == kpy else [("x", kpx), ("y", kpy)]

    def _args(self, axis: str) -> tuple[float, float, float, float]:
        return self.m, self._kp_eff(axis), self.gains.Gamma, self.gains.delta

    # ------------------------------------------------------------------ matrices

    def plant_matrices(self, axis: str = "x") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Numeric ``(A, B, C, D)`` of :func:`plant_matrices_sym` for one axis.

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        m, kp, _, _ = self._args(axis)
        return tuple(_f(M) for M in lambdified()["plant"](m, kp, 1.0, 1.0))  # type: ignore[return-value]

    def controller_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Numeric ``(Ac, Bc, Cc, Dc)`` of :func:`controller_matrices_sym` (the same on both axes)."""
        return tuple(_f(M) for M in lambdified()["controller"](1.0, 1.0, self.gains.Gamma, self.gains.delta))  # type: ignore[return-value]

    def plant_system(self, axis: str = "x") -> LinearSystem:
        """The reshaped plant of one axis as a :class:`nniquad.analysis.loops.LinearSystem` (F in N -> xi in m).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        return LinearSystem(*self.plant_matrices(axis))

    def controller_system(self) -> LinearSystem:
        """The integral resonant controller as a :class:`nniquad.analysis.loops.LinearSystem` (xi -> u_c)."""
        return LinearSystem(*self.controller_matrices())

    def plant_ss(self, axis: str = "x"):
        """The reshaped plant of one axis as a :class:`control.StateSpace` (input F in N, output xi in m).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        import control as ct

        return ct.ss(*self.plant_matrices(axis), inputs=["F"], outputs=["xi"], states=["xi", "xi_dot"], name="plant")

    def controller_ss(self):
        """The integral resonant controller of one axis as a :class:`control.StateSpace`."""
        import control as ct

        return ct.ss(*self.controller_matrices(), inputs=["xi"], outputs=["u_c"], states=["z"], name="controller")

    def closed_loop_ss(self, axis: str = "x"):
        """Closed loop of one axis by python-control's own interconnection (``feedback(sign=+1)``).

        Input: a force disturbance added to ``F`` (N); output: xi (m).  Its poles are an
        independent route to the eigenvalues of :meth:`closed_loop_A_axis`.

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        import control as ct

        return ct.feedback(self.plant_ss(axis), self.controller_ss(), sign=+1)

    def closed_loop_A_axis(self, axis: str = "x") -> np.ndarray:
        """Closed-loop A matrix of one axis, state ``[xi, xi_dot, z]`` (3x3).

        With ``m_nominal`` set it is ``A0 + B K`` of :meth:`saturation_split`
        (the nominal command scaled by ``m_nominal/m``).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        if self.m_nominal is not None:
            A0, B, K = self.saturation_split(axis)
            return A0 + B @ K
        return _f(lambdified()["A_cl"](*self._args(axis)))

    def closed_loop_A(self) -> np.ndarray:
        """Closed-loop A matrix of both axes (6x6, block diagonal), state ``[x, x_dot, z1, y, y_dot, z2]``."""
        out = np.zeros((6, 6))
        out[:3, :3], out[3:, 3:] = self.closed_loop_A_axis("x"), self.closed_loop_A_axis("y")
        return out

    def saturation_split(self, axis: str = "x") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Split one axis as ``x_dot = A0 x + B sat(K x)`` with ``K x`` the acceleration command.

        The horizontal acceleration of the reshaped plant is
        :math:`\\ddot\\xi = -k_p\\xi + z/m` (row ``xi_dot`` of :math:`A_{cl}`); the tilt limit
        saturates that command.  ``K`` is that row of the nominal closed loop,
        ``B = e_2`` and ``A0 = A_cl - B K``, so ``A0 + B K = A_cl`` exactly.  With
        ``m_nominal`` set, ``A0, K`` are those of the nominal loop and
        ``B = (m_nominal/m) e_2``: the plant realises the command scaled by the mass ratio.

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        mn = self.nominal_mass
        A_cl = _f(lambdified()["A_cl"](mn, self.kp(axis), self.gains.Gamma, self.gains.delta))
        B = np.zeros((3, 1))
        B[1, 0] = 1.0
        K = A_cl[1:2, :].copy()
        A0 = A_cl - B @ K
        if self.m_nominal is not None:
            B = (self.m_nominal / self.m) * B
        return A0, B, K

    # ------------------------------------------------------------------ verdicts

    @property
    def stable(self) -> bool:
        """Exact Routh-Hurwitz verdict for both axes (no eigenvalues computed)."""
        f = lambdified()["routh_lhs"]
        return all(float(f(*self._args(axis))) > 0 for axis, _ in self.axes)

    @property
    def margin_product(self) -> float:
        """``m kp δ`` of the weaker axis (dimensionless); the loop is stable iff it exceeds 1."""
        return min(self.m * self._kp_eff(axis) * self.gains.delta for axis, _ in self.axes)

    def characteristic_coefficients(self, axis: str = "x") -> np.ndarray:
        """Numeric coefficients ``[1, a2, a1, a0]`` of :func:`characteristic_polynomial`.

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        return _f(lambdified()["coeffs"](*self._args(axis)))

    def dc_loop_gain(self, axis: str = "x") -> float:
        """DC loop gain ``G(0) C(0)`` of one axis (= 1/(m kp δ)).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        m, kp, _, d = self._args(axis)
        return float(lambdified()["dc_gain"](m, kp, 1.0, d))

    @property
    def smallest_gamma(self) -> float:
        """Smallest γ with which the sector bound holds: ``1/(m min(kp) δ)``.

        The sector bound holds with some admissible γ ∈ (0, 1) iff this is < 1.
        """
        return max(self.dc_loop_gain(axis) for axis, _ in self.axes)

    @property
    def sector_bound_holds(self) -> bool:
        """Whether some γ ∈ (0, 1) satisfies the paper's sector bound (γ = 1 itself is not admissible)."""
        return self.smallest_gamma < 1.0

    def sector_delta_min(self, gamma: float) -> float:
        """Smallest δ that satisfies the paper's sector bound with a given γ.

        The paper's condition ``delta^2 >= 1/(gamma^2 m^2 min kp^2)``, with the
        smaller of the two axis gains.

        Parameters
        ----------
        gamma
            The sector gain γ (> 0).
        """
        g = positive_gain("gamma", gamma)
        kp = min(self._kp_eff(axis) for axis, _ in self.axes)
        return float(lambdified()["delta_min"](self.m, kp, g))

    def axis_scaling(self, axis: str = "x") -> np.ndarray:
        """Diagonal state scaling ``T = diag(1, sqrt(kp), Γ)`` of the decay LMIs of one axis
        (:func:`nniquad.analysis.lmi.decay.closed_loop_decay`): the velocity in units of the inner loop's natural
        frequency, the controller state in units of Γ.

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        return np.diag([1.0, float(np.sqrt(self.kp(axis))), self.gains.Gamma])

    def start_direction(self) -> np.ndarray:
        """The start state of one axis per metre of displacement from rest: ``[1, 0, 0]`` (controller state 0)."""
        return np.array([1.0, 0.0, 0.0])

    def controller_scaling(self) -> np.ndarray:
        """State scaling of the controller's NI lemma LMI: none (one state)."""
        return np.eye(1)

    def controller_normalisation(self) -> tuple[np.ndarray, float]:
        """``(T, time scale)`` in which ``verify`` judges the controller's NI storage: none for this law."""
        return np.eye(1), 1.0

    def min_stable_mass(self) -> float:
        """Smallest true mass of the paper model that keeps the loop stable: ``1/(min kp δ)`` [kg]."""
        return 1.0 / (min(self.gains.axes()) * self.gains.delta)

    @property
    def routh_margin(self) -> float:
        """``m kp δ - 1`` of the weaker axis (``= 1/γ - 1``): positive iff the loop is stable."""
        return self.margin_product - 1.0

    def poles_and_damping(self) -> PolesDamping:
        """Poles, natural frequencies and damping of the closed loop of both axes."""
        return self._damp(self.closed_loop_A())

    @staticmethod
    def _damp(A: np.ndarray) -> PolesDamping:
        """:class:`PolesDamping` of a closed-loop matrix.

        The definitions of python-control's ``damp`` (the tests compare the two):
        the poles are the eigenvalues of ``A``, ``wn = |p|`` and
        ``zeta = -Re(p)/|p|``.  numpy computes them, so a cold ``nniquad verify``
        does not import python-control for them.
        """
        poles = np.linalg.eigvals(A).astype(complex)
        wn = np.abs(poles)
        zeta = -poles.real / wn
        order = np.argsort(poles.real)[::-1]
        max_re = float(np.max(poles.real))
        return PolesDamping(
            poles=poles[order],
            wn=np.asarray(wn)[order],
            zeta=np.asarray(zeta)[order],
            max_real_part=max_re,
            min_damping=float(np.min(zeta)),
            decay_rate=-2.0 * max_re,
        )


#: The paper's loop: the paper vehicle with the paper's gains.
PAPER_LOOP = ReducedLoop.from_vehicle(PAPER_VEHICLE, PAPER_GAINS)
