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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import Callable

import numpy as np
import sympy as sp

from nniquad.errors import GainError
from nniquad.control.gains import positive_gain

__all__ = [
    "SYMBOLS",
    "plant_matrices_sym",
    "controller_matrices_sym",
    "closed_loop_matrix_sym",
    "characteristic_polynomial",
    "characteristic_coefficients",
    "routh_array",
    "routh_stability_region",
    "dc_loop_gain_sym",
    "plant_matrices",
    "controller_matrices",
    "plant_ss",
    "controller_ss",
    "closed_loop_A_axis",
    "closed_loop_A",
    "closed_loop_ss",
    "saturation_split",
    "stable",
    "stability_margin_product",
    "dc_loop_gain",
    "sector_delta_min",
    "smallest_gamma",
    "sector_bound_holds",
    "PolesDamping",
    "poles_and_damping",
]

#: Positive symbols of the reduced loop: mass m (kg), inner gain kp (1/s^2),
#: controller gain Gamma (N/(m s)) and controller parameter delta (m/N; C(0) = 1/delta).
SYMBOLS: dict[str, sp.Symbol] = {
    "m": sp.Symbol("m", positive=True),
    "kp": sp.Symbol("k_p", positive=True),
    "Gamma": sp.Symbol("Gamma", positive=True),
    "delta": sp.Symbol("delta", positive=True),
}
_S = sp.Symbol("s")
_ARGS = (SYMBOLS["m"], SYMBOLS["kp"], SYMBOLS["Gamma"], SYMBOLS["delta"])


# ----------------------------------------------------------------------------- gains







# ----------------------------------------------------------------------------- symbolic layer


def plant_matrices_sym() -> tuple[sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]:
    """Reshaped plant of one axis, :math:`m\\ddot\\xi + m k_p\\xi = F`, ``y = xi``.

    Returns
    -------
    A, B, C, D : sympy.Matrix
        State ``[xi, xi_dot]``; input the horizontal force F (N); output xi (m).
    """
    m, kp = SYMBOLS["m"], SYMBOLS["kp"]
    A = sp.Matrix([[0, 1], [-kp, 0]])
    B = sp.Matrix([[0], [1 / m]])
    C = sp.Matrix([[1, 0]])
    D = sp.zeros(1, 1)
    return A, B, C, D


def controller_matrices_sym() -> tuple[sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]:
    """Integral resonant controller :math:`C(s) = (s + \\Gamma\\delta)^{-1}\\Gamma`, one axis.

    Returns
    -------
    Ac, Bc, Cc, Dc : sympy.Matrix
        Realisation ``controller_state_space`` of the paper: state z, input xi, output z.
    """
    G, d = SYMBOLS["Gamma"], SYMBOLS["delta"]
    return sp.Matrix([[-G * d]]), sp.Matrix([[G]]), sp.Matrix([[1]]), sp.zeros(1, 1)


@cache
def closed_loop_matrix_sym() -> sp.Matrix:
    """Positive-feedback interconnection ``F = u_c``, controller input ``xi``, one axis.

    Built from :func:`plant_matrices_sym` and :func:`controller_matrices_sym`
    (both strictly proper, so the interconnection is well posed):
    :math:`A_{cl} = [[A, B C_c], [B_c C, A_c]]`.  State ``[xi, xi_dot, z]``.
    """
    A, B, C, D = plant_matrices_sym()
    Ac, Bc, Cc, Dc = controller_matrices_sym()
    # Well-posedness of a positive-feedback loop needs I - D Dc invertible; both are zero here.
    assert D.is_zero_matrix and Dc.is_zero_matrix
    return sp.BlockMatrix([[A, B * Cc], [Bc * C, Ac]]).as_explicit()


@cache
def characteristic_polynomial() -> sp.Poly:
    """Monic closed-loop characteristic polynomial ``det(sI - A_cl)`` of one axis, in ``s``."""
    A_cl = closed_loop_matrix_sym()
    return sp.Poly(sp.expand((_S * sp.eye(3) - A_cl).det()), _S)


def routh_array(poly: sp.Poly) -> list[list[sp.Expr]]:
    """Routh array of a polynomial with symbolic coefficients (regular case).

    Parameters
    ----------
    poly
        Polynomial in one variable; its leading coefficient must be positive.

    Returns
    -------
    list of rows; the first entries of the rows form the first column.
    """
    # cancel (not simplify): rational functions of the symbols, normalised quickly
    coeffs = [sp.cancel(c) for c in poly.all_coeffs()]
    n = len(coeffs)
    width = (n + 1) // 2
    rows = [coeffs[0::2] + [0] * (width - len(coeffs[0::2])), coeffs[1::2] + [0] * (width - len(coeffs[1::2]))]
    for _ in range(n - 2):
        upper, lower = rows[-2], rows[-1]
        new = [sp.cancel((lower[0] * upper[j + 1] - upper[0] * lower[j + 1]) / lower[0]) for j in range(width - 1)]
        rows.append(new + [0])
    return rows


@cache
def _routh_cached() -> tuple[tuple[sp.Expr, ...], tuple[sp.Expr, ...]]:
    rows = routh_array(characteristic_polynomial())
    first = tuple(sp.factor(r[0]) for r in rows)
    return first, tuple(c for c in first if c.is_positive is not True)


def routh_stability_region() -> dict[str, object]:
    """Exact stability region of one axis in (m, kp, Γ, δ), by Routh-Hurwitz.

    Returns
    -------
    dict
        ``first_column``: the Routh first-column entries (sympy);
        ``conditions``: the entries that are not positive for every positive
        data set (each must be > 0), simplified;
        ``reduced``: the equivalent single condition ``m*kp*delta - 1 > 0``
        (a sympy relational), checked to be equivalent by the tests.
    """
    first, conditions = _routh_cached()
    first, conditions = list(first), list(conditions)
    # drop the factors that are positive for all positive data: what is left is the region
    essential = [sp.Mul(*[f for f in sp.Mul.make_args(sp.factor(c)) if f.is_positive is not True]) for c in conditions]
    if len(essential) != 1:  # pragma: no cover - the model has exactly one essential condition
        raise RuntimeError(f"unexpected Routh conditions {essential}")
    return {"first_column": first, "conditions": conditions, "reduced": sp.StrictGreaterThan(sp.expand(essential[0]), 0)}


@cache
def dc_loop_gain_sym() -> sp.Expr:
    """DC loop gain :math:`G(0)C(0) = (-CA^{-1}B)(-C_cA_c^{-1}B_c)` of one axis."""
    A, B, C, _ = plant_matrices_sym()
    Ac, Bc, Cc, _ = controller_matrices_sym()
    g0 = (-C * A.inv() * B)[0, 0]
    c0 = (-Cc * Ac.inv() * Bc)[0, 0]
    return sp.simplify(g0 * c0)


@cache
def _lambdified() -> dict[str, Callable]:
    """Numeric functions generated once from the symbolic expressions."""
    A, B, C, D = plant_matrices_sym()
    Ac, Bc, Cc, Dc = controller_matrices_sym()
    gamma = sp.Symbol("gamma", positive=True)
    dc = dc_loop_gain_sym()
    delta_min = sp.solve(sp.Eq(dc, gamma), SYMBOLS["delta"])
    assert len(delta_min) == 1
    poly = characteristic_polynomial()
    reduced = routh_stability_region()["reduced"]
    f = lambda expr: sp.lambdify(_ARGS, expr, modules="numpy", cse=True)  # noqa: E731
    return {
        "plant": f([A, B, C, D]),
        "controller": f([Ac, Bc, Cc, Dc]),
        "A_cl": f(closed_loop_matrix_sym()),
        "coeffs": f(poly.all_coeffs()),
        "routh_lhs": f(reduced.lhs),
        "dc_gain": f(dc),
        "delta_min": sp.lambdify((SYMBOLS["m"], SYMBOLS["kp"], gamma), delta_min[0], modules="numpy"),
    }


# ----------------------------------------------------------------------------- numeric layer


def _f(array) -> np.ndarray:
    return np.array(array, dtype=float)


def plant_matrices(m: float, kp: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Numeric ``(A, B, C, D)`` of :func:`plant_matrices_sym`."""
    m, kp = positive_gain("m", m), positive_gain("kp", kp)
    return tuple(_f(M) for M in _lambdified()["plant"](m, kp, 1.0, 1.0))  # type: ignore[return-value]


def controller_matrices(Gamma: float, delta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Numeric ``(Ac, Bc, Cc, Dc)`` of :func:`controller_matrices_sym`."""
    G, d = positive_gain("Gamma", Gamma), positive_gain("delta", delta)
    return tuple(_f(M) for M in _lambdified()["controller"](1.0, 1.0, G, d))  # type: ignore[return-value]


def plant_ss(m: float, kp: float):
    """The reshaped plant of one axis as a :class:`control.StateSpace` (input F in N, output xi in m)."""
    import control as ct

    return ct.ss(*plant_matrices(m, kp), inputs=["F"], outputs=["xi"], states=["xi", "xi_dot"], name="plant")


def controller_ss(Gamma: float, delta: float):
    """The integral resonant controller of one axis as a :class:`control.StateSpace`."""
    import control as ct

    return ct.ss(*controller_matrices(Gamma, delta), inputs=["xi"], outputs=["u_c"], states=["z"], name="controller")


def closed_loop_A_axis(m: float, kp: float, Gamma: float, delta: float) -> np.ndarray:
    """Closed-loop A matrix of one axis, state ``[xi, xi_dot, z]`` (3x3)."""
    args = (positive_gain("m", m), positive_gain("kp", kp), positive_gain("Gamma", Gamma), positive_gain("delta", delta))
    return _f(_lambdified()["A_cl"](*args))


def closed_loop_A(m: float, kpx: float, Gamma: float, delta: float, kpy: float | None = None) -> np.ndarray:
    """Closed-loop A matrix of both axes (6x6, block diagonal).

    State ``[x, x_dot, z1, y, y_dot, z2]``; ``kpy=None`` means ``kpy = kpx``.
    """
    Ax = closed_loop_A_axis(m, kpx, Gamma, delta)
    Ay = closed_loop_A_axis(m, kpx if kpy is None else kpy, Gamma, delta)
    out = np.zeros((6, 6))
    out[:3, :3], out[3:, 3:] = Ax, Ay
    return out


def closed_loop_ss(m: float, kp: float, Gamma: float, delta: float):
    """Closed loop of one axis by python-control's own interconnection (``feedback(sign=+1)``).

    Input: a force disturbance added to ``F`` (N); output: xi (m).  Its poles are an
    independent route to the eigenvalues of :func:`closed_loop_A_axis`.
    """
    import control as ct

    return ct.feedback(plant_ss(m, kp), controller_ss(Gamma, delta), sign=+1)


def saturation_split(m: float, kp: float, Gamma: float, delta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split one axis as ``x_dot = A0 x + B sat(K x)`` with ``K x`` the acceleration command.

    The horizontal acceleration of the reshaped plant is
    :math:`\\ddot\\xi = -k_p\\xi + z/m` (row ``xi_dot`` of :math:`A_{cl}`); the tilt limit
    saturates that command.  ``K`` is that row of :func:`closed_loop_A_axis`,
    ``B = e_2`` and ``A0 = A_cl - B K``, so ``A0 + B K = A_cl`` exactly.
    """
    A_cl = closed_loop_A_axis(m, kp, Gamma, delta)
    B = np.zeros((3, 1))
    B[1, 0] = 1.0
    K = A_cl[1:2, :].copy()
    return A_cl - B @ K, B, K


def stable(m: float, kp: float, Gamma: float, delta: float, kpy: float | None = None) -> bool:
    """Exact Routh-Hurwitz verdict for both axes (no eigenvalues computed)."""
    f = _lambdified()["routh_lhs"]
    positive_gain("Gamma", Gamma)
    kps = [kp] if kpy is None else [kp, kpy]
    return all(float(f(positive_gain("m", m), positive_gain("kp", k), Gamma, positive_gain("delta", delta))) > 0 for k in kps)


def stability_margin_product(m: float, kp: float, delta: float) -> float:
    """``m kp δ`` (dimensionless); the loop is stable iff it exceeds 1."""
    return positive_gain("m", m) * positive_gain("kp", kp) * positive_gain("delta", delta)


def characteristic_coefficients(m: float, kp: float, Gamma: float, delta: float) -> np.ndarray:
    """Numeric coefficients ``[1, a2, a1, a0]`` of :func:`characteristic_polynomial`."""
    args = (positive_gain("m", m), positive_gain("kp", kp), positive_gain("Gamma", Gamma), positive_gain("delta", delta))
    return _f(_lambdified()["coeffs"](*args))


def dc_loop_gain(m: float, kp: float, delta: float) -> float:
    """DC loop gain ``G(0) C(0)`` of one axis (= 1/(m kp δ))."""
    return float(_lambdified()["dc_gain"](positive_gain("m", m), positive_gain("kp", kp), 1.0, positive_gain("delta", delta)))


def sector_delta_min(m: float, kp: float, gamma: float) -> float:
    """Smallest δ that satisfies the paper's sector bound with a given γ.

    The paper's condition ``delta^2 >= 1/(gamma^2 m^2 min kp^2)``; pass ``kp = min(kpx, kpy)``.
    """
    g = positive_gain("gamma", gamma)
    return float(_lambdified()["delta_min"](positive_gain("m", m), positive_gain("kp", kp), g))


def smallest_gamma(m: float, kpx: float, kpy: float | None, delta: float) -> float:
    """Smallest γ with which the sector bound holds for given gains: ``1/(m min(kp) δ)``.

    The sector bound holds with some admissible γ ∈ (0, 1) iff this is < 1.
    """
    kps = [kpx] if kpy is None else [kpx, kpy]
    return max(dc_loop_gain(m, k, delta) for k in kps)


def sector_bound_holds(m: float, kpx: float, kpy: float | None, delta: float) -> bool:
    """Whether some γ ∈ (0, 1) satisfies the paper's sector bound."""
    return smallest_gamma(m, kpx, kpy, delta) < 1.0


@dataclass(frozen=True)
class PolesDamping:
    """Closed-loop poles of both axes with natural frequencies and damping ratios.

    Attributes
    ----------
    poles : complex ndarray
        Eigenvalues of :func:`closed_loop_A` (1/s).
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
        return self.max_real_part < 0.0


def poles_and_damping(m: float, kp: float, Gamma: float, delta: float, kpy: float | None = None) -> PolesDamping:
    """Poles, natural frequencies and damping of the closed loop (python-control ``damp``)."""
    import control as ct

    A = closed_loop_A(m, kp, Gamma, delta, kpy)
    sys = ct.ss(A, np.zeros((6, 1)), np.zeros((1, 6)), 0)
    wn, zeta, poles = sys.damp()
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
