"""Symbolic layer of the reduced horizontal loop: written once, with sympy.

The plant and the controller of one axis are written in
:func:`plant_matrices_sym` and :func:`controller_matrices_sym`; the closed loop
is built from them by the positive-feedback interconnection formula
(:func:`closed_loop_matrix_sym`); the characteristic polynomial, its Routh
array and stability region, and the DC loop gain are derived from it.  The
numeric layer (:class:`nniquad.analysis.linear.ReducedLoop`) evaluates
:func:`lambdified` versions of exactly these expressions.  See
:mod:`nniquad.analysis.linear` for what is derived and checked.
"""

from __future__ import annotations

from functools import cache
from typing import Callable

import sympy as sp

__all__ = [
    "SYMBOLS",
    "plant_matrices_sym",
    "controller_matrices_sym",
    "closed_loop_matrix_sym",
    "characteristic_polynomial",
    "routh_array",
    "routh_stability_region",
    "dc_loop_gain_sym",
    "lambdified",
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
def lambdified() -> dict[str, Callable]:
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


