"""The reduced horizontal loop of any law of the NI structure: state space, Routh verdict, sector constant, poles.

The paper (Ghallab & Petersen, Section "Control design") reshapes each horizontal
axis by the inner proportional loop into

.. math:: m \\ddot\\xi + m k_p \\xi = F_h, \\qquad y = \\xi

(eq. ``compact_horizontal``), and closes the outer loop with a strictly
negative-imaginary controller in **positive** feedback, :math:`F_h = u_c` (the
paper's integral resonant controller :math:`C(s) = (s + \\Gamma\\delta)^{-1}\\Gamma`,
or the ``sni2`` law's second-order one: each law writes its controller once,
:meth:`nniquad.laws.base.NILaw.controller_realisation`).  The axes are
decoupled, so everything is per axis; they differ only through their inner
gains.

One source of truth
-------------------
The plant is written once, symbolically (:mod:`nniquad.analysis.reduced_loop_symbolic`),
the controller once, by its law; the closed loop is *built* from them by the
positive-feedback interconnection formula, never retyped.  The exact Routh
verdict and the characteristic polynomial are ``sympy.lambdify`` of the symbolic
closed loop (kept by :mod:`nniquad.codecache`, so a cold process does not import
sympy).  State per axis: ``[ξ, ξ', controller states]``.

What the symbolic layer derives (and the tests check against hand algebra), for
the NNI law: the characteristic polynomial :math:`s^3 + \\Gamma\\delta s^2 + k_p s +
\\Gamma(k_p\\delta - 1/m)`; Routh-Hurwitz: stable iff :math:`m k_p \\delta > 1`;
the DC loop gain :math:`G(0)C(0) = 1/(m k_p \\delta)`, so the paper's sector bound
is :math:`G(0)C(0) \\le \\gamma` and the smallest admissible γ is the DC loop gain
itself; the union over γ ∈ (0, 1) of the sector regions is exactly the Routh
region.  For every law of the structure the DC loop gain is the sector constant
(:meth:`nniquad.laws.base.NILaw.sector_constant`) and the law states the bound it
puts on its own gain (:meth:`~nniquad.laws.base.NILaw.sector_limit`).

Mass uncertainty follows the paper's model: the true mass ``m`` enters only
through the input matrix ``1/m`` (the inner loop's ``k_p`` is an acceleration
gain).  ``ReducedLoop(m, gains, m_nominal=m_hat)`` is the loop whose thrust is
sized with a nominal mass ``m_hat`` while the true mass is ``m`` (the model of
:mod:`nniquad.sim`); :meth:`ReducedLoop.with_mass` builds both true-mass models
from a nominal loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from nniquad import codecache
from nniquad.analysis.loops import LinearSystem
from nniquad.errors import GainError
from nniquad.laws.base import GainBlock, NILaw, positive_gain
from nniquad.laws.nni import PAPER_GAINS
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle

__all__ = ["ReducedLoop", "PAPER_LOOP", "PolesDamping", "reduced_loop", "lambdified"]


def lambdified(law: NILaw) -> dict:
    """The numeric functions lambdified from the symbolic layer of ``law``'s loop
    (:func:`nniquad.analysis.reduced_loop_symbolic.lambdified`).

    Their generated source is kept by :mod:`nniquad.codecache`; a process that
    finds it there does not import sympy.

    Parameters
    ----------
    law
        A law of the NI structure.
    """
    def build() -> dict:
        # lazily: sympy costs a cold command a third of a second, and the cache usually spares it
        from nniquad.analysis import reduced_loop_symbolic

        return reduced_loop_symbolic.lambdified(law)

    return codecache.cached_numpy_functions(f"nniquad.analysis.reduced_loop_symbolic.lambdified[{law.name}]", build)


def _f(array: Any) -> np.ndarray:
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

    @classmethod
    def of(cls, A: np.ndarray) -> "PolesDamping":
        """:class:`PolesDamping` of a closed-loop matrix.

        The definitions of python-control's ``damp`` (the tests compare the two):
        the poles are the eigenvalues of ``A``, ``wn = |p|`` and
        ``zeta = -Re(p)/|p|``.  numpy computes them, so a cold ``nniquad verify``
        does not import python-control for them.

        Parameters
        ----------
        A
            A closed-loop state matrix.
        """
        poles = np.linalg.eigvals(A).astype(complex)
        wn = np.abs(poles)
        zeta = -poles.real / wn
        order = np.argsort(poles.real)[::-1]
        max_re = float(np.max(poles.real))
        return cls(poles=poles[order], wn=np.asarray(wn)[order], zeta=np.asarray(zeta)[order],
                   max_real_part=max_re, min_damping=float(np.min(zeta)), decay_rate=-2.0 * max_re)


@dataclass(frozen=True)
class ReducedLoop:
    """The reduced horizontal closed loop of one vehicle mass and one gain set of the NI structure (both axes).

    Parameters
    ----------
    m
        The vehicle's (true) mass [kg].
    gains
        A gain block of a law of the NI structure (:class:`~nniquad.laws.nni.Gains`,
        :class:`~nniquad.laws.sni2.SNI2Gains`, ...).
    m_nominal
        ``None`` (default): the paper's reduced model, ``kp`` an exact acceleration
        gain.  A mass [kg]: the thrust is sized with this nominal mass, so the plant
        realises ``(m_nominal/m)`` times the commanded acceleration
        ``a = -kp ξ + z/m_nominal`` (the model of :mod:`nniquad.sim`).
        The loop is then the paper's loop at mass ``m`` with the effective inner gain
        ``kp m_nominal / m``.
    g
        Gravitational acceleration [m/s^2]; only the saturation (tilt-limit) analysis
        uses it.  Default: the paper vehicle's.

    Raises
    ------
    GainError
        If ``m`` or ``m_nominal`` is not a finite positive number, or ``gains`` are not of a law of the NI
        structure.
    """

    m: float
    gains: GainBlock
    m_nominal: float | None = None
    g: float = PAPER_VEHICLE.g

    def __post_init__(self) -> None:
        object.__setattr__(self, "m", positive_gain("m", self.m))
        law = getattr(self.gains, "law", None) if isinstance(self.gains, GainBlock) else None
        if not isinstance(law, NILaw):
            raise GainError(f"a reduced loop needs gains of a law of the NI structure, got "
                            f"{type(self.gains).__name__}")
        if self.m_nominal is not None:
            object.__setattr__(self, "m_nominal", positive_gain("m_nominal", self.m_nominal))
        object.__setattr__(self, "g", positive_gain("g", self.g))

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_vehicle(cls, vehicle: Vehicle, gains: GainBlock) -> "ReducedLoop":
        """The paper-model loop of ``vehicle`` (its mass and gravity) with ``gains``.

        Parameters
        ----------
        vehicle
            The vehicle; only ``m`` and ``g`` enter the reduced loop.
        gains
            A gain block of a law of the NI structure.
        """
        return cls(vehicle.m, gains, g=vehicle.g)

    @property
    def law(self) -> NILaw:
        """The law of the gains."""
        return self.gains.law  # type: ignore[return-value]

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

    def with_gains(self, gains: GainBlock) -> "ReducedLoop":
        """The same vehicle with another gain set.

        Parameters
        ----------
        gains
            The new gain block.
        """
        return ReducedLoop(self.m, gains, self.m_nominal, self.g)

    # ------------------------------------------------------------------ gains per axis

    def kp(self, axis: str = "x") -> float:
        """The inner gain of an axis (``'x'`` or ``'y'``) as designed [1/s^2].

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        if axis not in _AXES:
            raise GainError(f"axis must be 'x' or 'y', got {axis!r}")
        return self.gains.axes()[_AXES.index(axis)]

    def _kp_eff(self, axis: str) -> float:
        """Inner gain the plant realises: ``kp`` (paper model) or ``kp m_nominal / m``."""
        kp = self.kp(axis)
        return kp if self.m_nominal is None else kp * self.m_nominal / self.m

    @property
    def axes(self) -> list[tuple[str, float]]:
        """``[('x', kpx)]`` when both axes share ``kp``, else ``[('x', kpx), ('y', kpy)]``."""
        kpx, kpy = self.gains.axes()
        return [("x", kpx)] if kpx == kpy else [("x", kpx), ("y", kpy)]

    def _args(self, axis: str, m: float | None = None, kp: float | None = None) -> tuple[float, ...]:
        """``(m, kp_eff, *controller gains)``: the arguments of the lambdified functions."""
        ctrl = [v for k, v in self.gains.values().items() if k not in ("kp", "kpy")]
        return (self.m if m is None else m, self._kp_eff(axis) if kp is None else kp, *ctrl)

    @property
    def n_axis(self) -> int:
        """States of one axis: ``ξ, ξ'`` and the controller's."""
        return 2 + self.law.n_states

    # ------------------------------------------------------------------ matrices

    def plant_matrices(self, axis: str = "x") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Numeric ``(A, B, C, D)`` of the reshaped plant of one axis (input F [N], output ξ [m]).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        return tuple(_f(M) for M in lambdified(self.law)["plant"](*self._args(axis)))  # type: ignore[return-value]

    def controller_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Numeric ``(Ac, Bc, Cc, Dc)`` of the law's controller (the same on both axes)."""
        return self.law.controller_matrices(self.gains)  # type: ignore[return-value]

    def plant_system(self, axis: str = "x") -> LinearSystem:
        """The reshaped plant of one axis as a :class:`nniquad.analysis.loops.LinearSystem` (F in N -> xi in m).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        return LinearSystem(*self.plant_matrices(axis))

    def controller_system(self) -> LinearSystem:
        """The law's controller as a :class:`nniquad.analysis.loops.LinearSystem` (xi -> u_c)."""
        return LinearSystem(*self.controller_matrices())

    def plant_ss(self, axis: str = "x") -> Any:
        """The reshaped plant of one axis as a :class:`control.StateSpace` (input F in N, output xi in m).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        import control as ct  # lazily: python-control costs a cold command half a second

        return ct.ss(*self.plant_matrices(axis), inputs=["F"], outputs=["xi"], states=["xi", "xi_dot"], name="plant")

    def controller_ss(self) -> Any:
        """The law's controller of one axis as a :class:`control.StateSpace`."""
        import control as ct  # lazily: as in plant_ss

        return ct.ss(*self.controller_matrices(), inputs=["xi"], outputs=["u_c"], states=list(self.law.state_names),
                     name="controller")

    def closed_loop_ss(self, axis: str = "x") -> Any:
        """Closed loop of one axis by python-control's own interconnection (``feedback(sign=+1)``).

        Input: a force disturbance added to ``F`` (N); output: xi (m).  Its poles are an
        independent route to the eigenvalues of :meth:`closed_loop_A_axis`.

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        import control as ct  # lazily: as in plant_ss

        return ct.feedback(self.plant_ss(axis), self.controller_ss(), sign=+1)

    def _interconnection(self, m: float, kp: float) -> np.ndarray:
        """``[[A_p, B_p C_c], [B_c C_p, A_c]]`` of the plant at mass ``m`` and inner gain ``kp``."""
        return _f(lambdified(self.law)["A_cl"](*self._args("x", m, kp)))

    def closed_loop_A_axis(self, axis: str = "x") -> np.ndarray:
        """Closed-loop A matrix of one axis, state ``[ξ, ξ', controller states]``.

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
        return self._interconnection(self.m, self._kp_eff(axis))

    def closed_loop_A(self) -> np.ndarray:
        """Closed-loop A matrix of both axes (block diagonal), state ``[x, x', ctrl_x, y, y', ctrl_y]``."""
        n = self.n_axis
        out = np.zeros((2 * n, 2 * n))
        out[:n, :n], out[n:, n:] = self.closed_loop_A_axis("x"), self.closed_loop_A_axis("y")
        return out

    def saturation_split(self, axis: str = "x") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Split one axis as ``x_dot = A0 x + B sat(K x)`` with ``K x`` the acceleration command.

        The horizontal acceleration of the reshaped plant is ``ξ'' = -k_p ξ + z/m`` (row ``ξ'`` of
        :math:`A_{cl}`); the tilt limit saturates that command.  ``K`` is that row of the nominal closed loop,
        ``B = e_2`` and ``A0 = A_cl - B K``, so ``A0 + B K = A_cl`` exactly.  With ``m_nominal`` set, ``A0, K``
        are those of the nominal loop and ``B = (m_nominal/m) e_2``: the plant realises the command scaled by
        the mass ratio.

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        A_cl = self._interconnection(self.nominal_mass, self.kp(axis))
        B = np.zeros((self.n_axis, 1))
        B[1, 0] = 1.0
        K = A_cl[1:2, :].copy()
        A0 = A_cl - B @ K
        if self.m_nominal is not None:
            B = (self.m_nominal / self.m) * B
        return A0, B, K

    # ------------------------------------------------------------------ verdicts

    @property
    def stable(self) -> bool:
        """Exact Routh-Hurwitz verdict for both axes: every first-column entry positive (no eigenvalues)."""
        f = lambdified(self.law)["routh_first_column"]
        return all(float(v) > 0 for axis, _ in self.axes for v in f(*self._args(axis)))

    @property
    def margin_product(self) -> float:
        """``1/γ`` of the weaker axis (``m kp δ`` for the NNI law); the loop is stable iff it exceeds 1."""
        return 1.0 / self.smallest_gamma

    def characteristic_coefficients(self, axis: str = "x") -> np.ndarray:
        """Numeric coefficients ``[1, a_{n-1}, ..., a_0]`` of the characteristic polynomial of one axis.

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        return _f(lambdified(self.law)["coeffs"](*self._args(axis)))

    def dc_loop_gain(self, axis: str = "x") -> float:
        """DC loop gain ``G(0) C(0)`` of one axis (``1/(m kp δ)`` for the NNI law).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        return self.law.dc_loop_gain(self.gains, self.m, self._kp_eff(axis))

    @property
    def smallest_gamma(self) -> float:
        """Smallest γ with which the sector bound holds: the DC loop gain of the weaker axis.

        The sector bound holds with some admissible γ ∈ (0, 1) iff this is < 1.
        """
        return max(self.dc_loop_gain(axis) for axis, _ in self.axes)

    @property
    def sector_bound_holds(self) -> bool:
        """Whether some γ ∈ (0, 1) satisfies the paper's sector bound (γ = 1 itself is not admissible)."""
        return self.smallest_gamma < 1.0

    def sector_limit(self, gamma: float) -> tuple[str, float]:
        """The bound the sector constant ``gamma`` puts on the law's own gain, with the weaker axis's inner gain:
        ``("delta_min", 1/(γ m kp))`` for the NNI law, ``("k_max", γ m kp ω²)`` for ``sni2``.

        Parameters
        ----------
        gamma
            The sector gain γ (> 0).
        """
        g = positive_gain("gamma", gamma)
        kp = min(self._kp_eff(axis) for axis, _ in self.axes)
        return self.law.sector_limit(self.gains, self.m, kp, g)

    def axis_scaling(self, axis: str = "x") -> np.ndarray:
        """Diagonal state scaling of the decay LMIs of one axis
        (:func:`nniquad.analysis.lmi.decay.closed_loop_decay`; :meth:`nniquad.laws.base.NILaw.axis_scaling`).

        Parameters
        ----------
        axis
            ``'x'`` or ``'y'``.
        """
        return self.law.axis_scaling(self.gains, self.kp(axis), self.nominal_mass)

    def start_direction(self) -> np.ndarray:
        """The start state of the x axis per metre of displacement from rest: ``[1, 0, controller start]`` (the
        law's take-over state, :meth:`nniquad.laws.base.ControlLaw.start_map`)."""
        S = self.law.start_map(self.gains, self.nominal_mass)
        return np.concatenate([[1.0, 0.0], S[0::2, 0]])

    def controller_scaling(self) -> np.ndarray:
        """State scaling of the controller's NI lemma LMI (:meth:`nniquad.laws.base.NILaw.controller_scaling`)."""
        return self.law.controller_scaling(self.gains)

    def controller_normalisation(self) -> tuple[np.ndarray, float]:
        """``(T, time scale)`` in which ``verify`` judges the controller's NI storage."""
        return self.law.controller_normalisation(self.gains)

    def min_stable_mass(self) -> float:
        """Smallest true mass of the paper model that keeps the loop stable [kg]."""
        return self.law.min_stable_mass(self.gains)

    @property
    def routh_margin(self) -> float:
        """``1/γ - 1`` of the weaker axis (``m kp δ - 1`` for the NNI law): positive iff the loop is stable."""
        return self.margin_product - 1.0

    def poles_and_damping(self) -> PolesDamping:
        """Poles, natural frequencies and damping of the closed loop of both axes."""
        return PolesDamping.of(self.closed_loop_A())


def reduced_loop(vehicle: Vehicle, gains: GainBlock) -> ReducedLoop:
    """The reduced loop of ``vehicle`` with a gain set of the NI structure (:meth:`ReducedLoop.from_vehicle`).

    Parameters
    ----------
    vehicle
        The vehicle.
    gains
        A gain block of a law of the NI structure.

    Raises
    ------
    GainError
        A gain block of a law without this structure (a PD law).
    """
    return ReducedLoop.from_vehicle(vehicle, gains)


#: The paper's loop: the paper vehicle with the paper's gains.
PAPER_LOOP = ReducedLoop.from_vehicle(PAPER_VEHICLE, PAPER_GAINS)
