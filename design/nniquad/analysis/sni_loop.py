"""The reduced horizontal loop of the ``sni2`` law: the reshaped plant with the second-order SNI controller.

The plant of one axis is the paper's reshaped plant (:func:`nniquad.analysis.linear.plant_matrices_sym`,
``m ξ'' + m k_p ξ = F``, state ``[ξ, ξ']``), the controller the realisation of
:func:`nniquad.control.sni.realisation` (state ``[z, z']``), in positive feedback ``F = z``.  The
closed loop of one axis, state ``[ξ, ξ', z, z']``, is built from them by the interconnection formula
``[[A_p, B_p C_c], [B_c C_p, A_c]]`` (both parts strictly proper), never retyped.

:class:`SNI2Loop` offers what :class:`nniquad.analysis.linear.ReducedLoop` offers the certificate,
the LMIs and the tuner (the same method names): matrices of the plant, the controller and the closed
loop, the saturation split ``x' = A0 x + B sat(K x)``, the DC loop gain (the sector constant, the
exact stability condition ``γ < 1``: :mod:`nniquad.control.sni`), the poles, and the true-mass models
(the paper's, ``k_p`` exact; or the thrust sized with the nominal mass, as in :mod:`nniquad.sim`).
:func:`reduced_loop` picks the class from the type of the gains.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nniquad.analysis.linear import PolesDamping, ReducedLoop, lambdified
from nniquad.control.gains import Gains, SNI2Gains, positive_gain
from nniquad.control.sni import controller_matrices as _controller_matrices
from nniquad.control.sni import dc_loop_gain, start_direction
from nniquad.errors import GainError
from nniquad.model.vehicle import PAPER_VEHICLE, Vehicle

__all__ = ["SNI2Loop", "reduced_loop"]

_AXES = ("x", "y")


@dataclass(frozen=True)
class SNI2Loop:
    """The reduced loop of one vehicle mass and one ``sni2`` gain set (both axes alike).

    Parameters
    ----------
    m
        The vehicle's (true) mass [kg].
    gains
        The :class:`~nniquad.control.gains.SNI2Gains` block.
    m_nominal
        ``None``: the paper's reduced model (``k_p`` an exact acceleration gain).  A mass [kg]: the
        thrust is sized with this nominal mass, so the plant realises ``m_nominal/m`` times the command
        ``-k_p ξ + z/m_nominal`` (the model of :mod:`nniquad.sim`).
    g
        Gravitational acceleration [m/s²] (the saturation analysis only).
    """

    m: float
    gains: SNI2Gains
    m_nominal: float | None = None
    g: float = PAPER_VEHICLE.g

    def __post_init__(self) -> None:
        object.__setattr__(self, "m", positive_gain("m", self.m))
        if not isinstance(self.gains, SNI2Gains):
            raise GainError(f"an sni2 reduced loop needs an SNI2Gains block, got {type(self.gains).__name__}")
        if self.m_nominal is not None:
            object.__setattr__(self, "m_nominal", positive_gain("m_nominal", self.m_nominal))
        object.__setattr__(self, "g", positive_gain("g", self.g))

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_vehicle(cls, vehicle: Vehicle, gains: SNI2Gains) -> "SNI2Loop":
        """The paper-model loop of ``vehicle`` (its mass and gravity) with ``gains``."""
        return cls(vehicle.m, gains, g=vehicle.g)

    @property
    def nominal_mass(self) -> float:
        """The mass the controller is designed for [kg]."""
        return self.m if self.m_nominal is None else self.m_nominal

    def with_mass(self, m_true: float, *, thrust_model: bool = False) -> "SNI2Loop":
        """The same controller on a vehicle of true mass ``m_true`` (see :meth:`ReducedLoop.with_mass`)."""
        return SNI2Loop(m_true, self.gains, self.nominal_mass if thrust_model else None, self.g)

    def with_gains(self, gains: SNI2Gains) -> "SNI2Loop":
        """The same vehicle with another gain set."""
        return SNI2Loop(self.m, gains, self.m_nominal, self.g)

    # ------------------------------------------------------------------ gains
    def kp(self, axis: str = "x") -> float:
        """The inner gain of an axis as designed [1/s²] (both axes share it)."""
        if axis not in _AXES:
            raise GainError(f"axis must be 'x' or 'y', got {axis!r}")
        return self.gains.kp

    def _kp_eff(self, axis: str) -> float:
        kp = self.kp(axis)
        return kp if self.m_nominal is None else kp * self.m_nominal / self.m

    @property
    def axes(self) -> list[tuple[str, float]]:
        """``[('x', kp)]``: both axes share the gains."""
        return [("x", self.gains.kp)]

    # ------------------------------------------------------------------ matrices
    def plant_matrices(self, axis: str = "x") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C, D)`` of the reshaped plant of one axis (the NNI law's, :func:`plant_matrices_sym`)."""
        return tuple(np.array(M, dtype=float) for M in lambdified()["plant"](self.m, self._kp_eff(axis), 1.0, 1.0))  # type: ignore[return-value]

    def controller_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A_c, B_c, C_c, D_c)`` of one axis (:func:`nniquad.control.sni.controller_matrices`)."""
        g = self.gains
        return _controller_matrices(g.k, g.omega, g.zeta)

    def start_direction(self) -> np.ndarray:
        """The start state of one axis per metre of displacement from rest, ``[1, 0, C(0), 0]``: the controller at
        rest at its DC value (:func:`nniquad.control.sni.start_state`, what the simulator and the export do)."""
        return start_direction(self.gains.k, self.gains.omega)

    def controller_normalisation(self) -> tuple[np.ndarray, float]:
        """``(T, ω)``: :meth:`controller_scaling` and the time in units of ``1/ω``, in which the controller is
        ``[[0, 1], [-1, -2ζ]]``, ``[0, 1]``, ``[C(0), 0]`` and every term of the NI dissipation matrix is of
        order ``C(0)`` (``verify`` judges the stored storage there)."""
        return self.controller_scaling(), float(self.gains.omega)

    def controller_scaling(self) -> np.ndarray:
        """Diagonal state scaling ``T`` of the controller for its NI lemma LMI: ``z`` in units of ``C(0) = k/ω²``
        per metre, ``z'`` in units of ``k/ω`` (the realisation ``(T⁻¹A_cT, T⁻¹B_c, C_cT)`` is then of order ω and 1)."""
        g = self.gains
        return np.diag([g.k / g.omega**2, g.k / g.omega])

    def _interconnection(self, m: float, kp: float) -> np.ndarray:
        A_p, B_p, C_p, _ = (np.array(M, dtype=float) for M in lambdified()["plant"](m, kp, 1.0, 1.0))
        A_c, B_c, C_c, _ = self.controller_matrices()
        return np.block([[A_p, B_p @ C_c], [B_c @ C_p, A_c]])

    def closed_loop_A_axis(self, axis: str = "x") -> np.ndarray:
        """Closed-loop matrix of one axis, state ``[ξ, ξ', z, z']`` (4x4); with ``m_nominal``: ``A0 + B K``."""
        if self.m_nominal is not None:
            A0, B, K = self.saturation_split(axis)
            return A0 + B @ K
        return self._interconnection(self.m, self.kp(axis))

    def closed_loop_A(self) -> np.ndarray:
        """Closed-loop matrix of both axes (8x8, block diagonal), state ``[x, x', z_x, z'_x, y, y', z_y, z'_y]``."""
        n = 4
        out = np.zeros((2 * n, 2 * n))
        out[:n, :n], out[n:, n:] = self.closed_loop_A_axis("x"), self.closed_loop_A_axis("y")
        return out

    def saturation_split(self, axis: str = "x") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``x' = A0 x + B sat(K x)``, ``K x = -k_p ξ + z/m`` the acceleration command (row ``ξ'`` of the
        nominal closed loop); with ``m_nominal`` the plant realises ``(m_nominal/m)`` times it."""
        A_cl = self._interconnection(self.nominal_mass, self.kp(axis))
        B = np.zeros((4, 1))
        B[1, 0] = 1.0
        K = A_cl[1:2, :].copy()
        A0 = A_cl - B @ K
        if self.m_nominal is not None:
            B = (self.m_nominal / self.m) * B
        return A0, B, K

    def axis_scaling(self, axis: str = "x") -> np.ndarray:
        """Diagonal state scaling of the decay LMIs of one axis: position in m, velocity in units of ``sqrt(k_p)``,
        ``z`` in units of ``m k_p`` (``z/m`` balances ``k_p ξ``), ``z'`` in units of ``m k_p ω``."""
        kp = self.kp(axis)
        mk = self.nominal_mass * kp
        return np.diag([1.0, np.sqrt(kp), mk, mk * self.gains.omega])

    # ------------------------------------------------------------------ verdicts
    def dc_loop_gain(self, axis: str = "x") -> float:
        """``P(0) C(0) = k/(m k_p ω²)`` of one axis (with the effective inner gain of the mass model)."""
        g = self.gains
        return dc_loop_gain(self.m, self._kp_eff(axis), g.k, g.omega)

    @property
    def smallest_gamma(self) -> float:
        """The DC loop gain γ: the smallest sector constant the gains satisfy; the loop is stable iff ``γ < 1``."""
        return max(self.dc_loop_gain(axis) for axis, _ in self.axes)

    @property
    def sector_bound_holds(self) -> bool:
        """Whether some γ in (0, 1) bounds the DC loop gain."""
        return self.smallest_gamma < 1.0

    def sector_k_max(self, gamma: float) -> float:
        """Largest controller gain ``k`` [N/(m s²)] whose DC loop gain is at most ``gamma``: ``γ m k_p ω²``."""
        g = positive_gain("gamma", gamma)
        return g * self.m * min(self._kp_eff(a) for a, _ in self.axes) * self.gains.omega ** 2

    @property
    def stable(self) -> bool:
        """Exact Routh-Hurwitz verdict (:mod:`nniquad.control.sni`): ``γ < 1``, with ``ζ, ω, k, k_p > 0``."""
        return self.smallest_gamma < 1.0

    def min_stable_mass(self) -> float:
        """Smallest true mass of the paper model that keeps the loop stable: ``k/(k_p ω²)`` [kg] (``γ(m) < 1``)."""
        g = self.gains
        return g.k / (g.kp * g.omega**2)

    @property
    def routh_margin(self) -> float:
        """``1/γ - 1``: positive iff the loop is stable (for the NNI law the same number is ``m k_p δ - 1``)."""
        return 1.0 / self.smallest_gamma - 1.0

    def poles_and_damping(self) -> PolesDamping:
        """Poles, natural frequencies and damping of the closed loop of both axes (python-control ``damp``)."""
        return ReducedLoop._damp(self.closed_loop_A())


def reduced_loop(vehicle: Vehicle, gains: Gains | SNI2Gains) -> ReducedLoop | SNI2Loop:
    """The reduced loop of a gain set of the NI structure: :class:`ReducedLoop` (NNI) or :class:`SNI2Loop`.

    Raises
    ------
    GainError
        A gain block of a law without this structure (a PD law).
    """
    if isinstance(gains, SNI2Gains):
        return SNI2Loop.from_vehicle(vehicle, gains)
    if isinstance(gains, Gains):
        return ReducedLoop.from_vehicle(vehicle, gains)
    raise GainError(f"no reduced NI loop for a {type(gains).__name__} gain block")
