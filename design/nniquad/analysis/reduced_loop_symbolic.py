"""Symbolic layer of the reduced horizontal loop of any law of the NI structure: written once, with sympy.

The reshaped plant of one axis is written in :func:`plant_matrices_sym`; the
controller is the law's own realisation (:meth:`nniquad.laws.base.NILaw.controller_realisation`,
:func:`controller_matrices_sym`); the closed loop is built from them by the
positive-feedback interconnection formula (:func:`closed_loop_matrix_sym`); the
characteristic polynomial, its Routh array and stability region, and the DC loop
gain are derived from it.  The numeric layer
(:class:`nniquad.analysis.reduced_loop.ReducedLoop`) evaluates :func:`lambdified`
versions of exactly these expressions.  Every function takes the law (default:
the paper's NNI law, whose symbols are :data:`SYMBOLS`).
"""

from __future__ import annotations

from functools import cache
from typing import Callable

import sympy as sp

from nniquad.laws.base import NILaw
from nniquad.laws.nni import NNI

__all__ = [
    "SYMBOLS",
    "law_symbols",
    "plant_matrices_sym",
    "controller_matrices_sym",
    "closed_loop_matrix_sym",
    "characteristic_polynomial",
    "routh_array",
    "routh_stability_region",
    "dc_loop_gain_sym",
    "lambdified",
]

#: Positive symbols of the reduced loop of the NNI law: mass m (kg), inner gain kp (1/s^2),
#: controller gain Gamma (N/(m s)) and controller parameter delta (m/N; C(0) = 1/delta).
SYMBOLS: dict[str, sp.Symbol] = {
    "m": sp.Symbol("m", positive=True),
    "kp": sp.Symbol("k_p", positive=True),
    "Gamma": sp.Symbol("Gamma", positive=True),
    "delta": sp.Symbol("delta", positive=True),
}
_S = sp.Symbol("s")


def law_symbols(law: NILaw = NNI) -> tuple[sp.Symbol, ...]:
    """The positive symbols of a law's controller, in the order of its gains (the inner gains ``kp``, ``kpy`` left
    out: the plant holds ``kp``).

    Parameters
    ----------
    law
        A law of the NI structure.
    """
    names = [n for n in law.gain_names if n not in ("kp", "kpy")]
    return tuple(SYMBOLS.get(n, sp.Symbol(n, positive=True)) for n in names)


def _args(law: NILaw) -> tuple[sp.Symbol, ...]:
    return (SYMBOLS["m"], SYMBOLS["kp"]) + law_symbols(law)


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


def controller_matrices_sym(law: NILaw = NNI) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]:
    """The law's SNI controller of one axis (for the NNI law :math:`C(s) = (s + \\Gamma\\delta)^{-1}\\Gamma`, the
    paper's realisation ``controller_state_space``: state z, input xi, output z).

    Parameters
    ----------
    law
        A law of the NI structure.

    Returns
    -------
    Ac, Bc, Cc, Dc : sympy.Matrix
    """
    p = dict(zip((n for n in law.gain_names if n not in ("kp", "kpy")), law_symbols(law)))
    Ac, Bc, Cc, Dc = law.controller_realisation(p)
    n = law.n_states
    return (sp.Matrix(n, n, [sp.nsimplify(e) for r in Ac for e in r]),
            sp.Matrix(n, 1, [sp.nsimplify(e) for r in Bc for e in r]),
            sp.Matrix(1, n, [sp.nsimplify(e) for r in Cc for e in r]),
            sp.Matrix(1, 1, [sp.nsimplify(Dc[0][0])]))


@cache
def closed_loop_matrix_sym(law: NILaw = NNI) -> sp.Matrix:
    """Positive-feedback interconnection ``F = u_c``, controller input ``xi``, one axis.

    Built from :func:`plant_matrices_sym` and :func:`controller_matrices_sym`
    (both strictly proper, so the interconnection is well posed):
    :math:`A_{cl} = [[A, B C_c], [B_c C, A_c]]`.  State ``[xi, xi_dot, controller states]``.

    Parameters
    ----------
    law
        A law of the NI structure.
    """
    A, B, C, D = plant_matrices_sym()
    Ac, Bc, Cc, Dc = controller_matrices_sym(law)
    # Well-posedness of a positive-feedback loop needs I - D Dc invertible; both are zero here.
    if not (D.is_zero_matrix and Dc.is_zero_matrix):
        raise ValueError(f"the {law.name} law's controller is not strictly proper: the interconnection is not "
                         "written for that")
    return sp.BlockMatrix([[A, B * Cc], [Bc * C, Ac]]).as_explicit()


@cache
def characteristic_polynomial(law: NILaw = NNI) -> sp.Poly:
    """Monic closed-loop characteristic polynomial ``det(sI - A_cl)`` of one axis, in ``s``.

    Parameters
    ----------
    law
        A law of the NI structure.
    """
    A_cl = closed_loop_matrix_sym(law)
    return sp.Poly(sp.expand((_S * sp.eye(A_cl.shape[0]) - A_cl).det()), _S)


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
def _routh_cached(law: NILaw = NNI) -> tuple[tuple[sp.Expr, ...], tuple[sp.Expr, ...]]:
    rows = routh_array(characteristic_polynomial(law))
    first = tuple(sp.factor(r[0]) for r in rows)
    return first, tuple(c for c in first if c.is_positive is not True)


def routh_stability_region(law: NILaw = NNI) -> dict[str, object]:
    """Exact stability region of one axis in (m, kp, the law's gains), by Routh-Hurwitz.

    Parameters
    ----------
    law
        A law of the NI structure.

    Returns
    -------
    dict
        ``first_column``: the Routh first-column entries (sympy);
        ``conditions``: the entries that are not positive for every positive
        data set (each must be > 0), simplified;
        ``reduced``: the equivalent single condition (for the NNI law ``m*kp*delta - 1 > 0``,
        a sympy relational), checked to be equivalent by the tests.

    Raises
    ------
    ValueError
        The region is not one condition (the first column is still available from :func:`lambdified`).
    """
    first, conditions = _routh_cached(law)
    first, conditions = list(first), list(conditions)
    # drop the factors that are positive for all positive data: what is left is the region
    essential = [sp.Mul(*[f for f in sp.Mul.make_args(sp.factor(c)) if f.is_positive is not True]) for c in conditions]
    if len(set(essential)) != 1:
        raise ValueError(f"the Routh region of the {law.name} law is not one condition: {essential}")
    return {"first_column": first, "conditions": conditions, "reduced": sp.StrictGreaterThan(sp.expand(essential[0]), 0)}


@cache
def dc_loop_gain_sym(law: NILaw = NNI) -> sp.Expr:
    """DC loop gain :math:`G(0)C(0) = (-CA^{-1}B)(-C_cA_c^{-1}B_c)` of one axis.

    Parameters
    ----------
    law
        A law of the NI structure.
    """
    A, B, C, _ = plant_matrices_sym()
    Ac, Bc, Cc, _ = controller_matrices_sym(law)
    g0 = (-C * A.inv() * B)[0, 0]
    c0 = (-Cc * Ac.inv() * Bc)[0, 0]
    return sp.simplify(g0 * c0)


@cache
def lambdified(law: NILaw = NNI) -> dict[str, Callable]:
    """Numeric functions generated once from the symbolic expressions, each of ``(m, kp, *controller gains)``.

    ``plant``, ``A_cl``, ``coeffs`` (of the characteristic polynomial), ``routh_first_column`` and ``dc_gain``.

    Parameters
    ----------
    law
        A law of the NI structure.
    """
    A, B, C, D = plant_matrices_sym()
    first, _ = _routh_cached(law)
    f = lambda expr: sp.lambdify(_args(law), expr, modules="numpy", cse=True)  # noqa: E731
    return {
        "plant": f([A, B, C, D]),
        "A_cl": f(closed_loop_matrix_sym(law)),
        "coeffs": f(characteristic_polynomial(law).all_coeffs()),
        "routh_first_column": f(list(first)),
        "dc_gain": f(dc_loop_gain_sym(law)),
    }
