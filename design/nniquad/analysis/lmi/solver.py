"""Solver plumbing of the LMIs: the result type, data checks, Clarabel and cvxpy's status mapping.

* Infeasibility is a legitimate answer: ``feasible=False`` and ``status`` is the
  solver's status string (``'infeasible'``).
* A solver crash, an ``'unbounded'`` status or non-finite data raise
  :class:`nniquad.errors.SolverError`; nothing returns a silent ``None``.
* The solver's word alone never certifies anything: every family re-checks the
  returned matrices with the numpy functions of :mod:`nniquad.analysis.lmi.checks`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from nniquad.errors import SolverError

__all__ = ["LMIResult", "as_data", "solve", "solved", "cpsym", "result_fail"]


@dataclass
class LMIResult:
    """Answer of one LMI, with the independent numpy re-check.

    Attributes
    ----------
    name
        Identifier of the LMI (e.g. ``'ni_lemma_paper[plant]'``).
    feasible
        True only if the solver returned a solution *and* the numpy re-check passed.
    status
        cvxpy's status string (``'optimal'``, ``'infeasible'``, ...).
    matrices
        Returned matrices (``P``, ``Y``, the data ``A``, ...), as numpy arrays.
    residuals
        Independent re-check quantities (relative, dimensionless unless the key says otherwise).
    margin
        The strictness margin achieved (its meaning is stated in ``note``).
    tolerance
        The relative tolerance the residuals were checked against.
    note
        What was solved, what the margin means, and anything the reader must know.
    values
        Named scalar results (decay rates in 1/s, displacement in m, ...).
    """

    name: str
    feasible: bool
    status: str
    matrices: dict[str, np.ndarray]
    residuals: dict[str, float]
    margin: float
    tolerance: float
    note: str = ""
    values: dict[str, float] = field(default_factory=dict)

    def __repr__(self) -> str:
        margin = f"{self.margin:.5g}" if math.isfinite(self.margin) else "-"
        keys = ", ".join(f"{k}={v:.4g}" for k, v in self.values.items() if k in ("decay_rate", "max_displacement_m"))
        return (f"LMIResult({self.name!r}, feasible={bool(self.feasible)}, status={self.status!r}, margin={margin}"
                + (f", {keys}" if keys else "") + f", matrices={sorted(self.matrices)})")

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dictionary (matrices as nested lists, non-finite numbers as strings)."""

        def num(x: float) -> float | str:
            x = float(x)
            return x if math.isfinite(x) else str(x)

        return {
            "name": self.name,
            "feasible": bool(self.feasible),
            "status": self.status,
            "margin": num(self.margin),
            "tolerance": self.tolerance,
            "residuals": {k: num(v) for k, v in self.residuals.items()},
            "values": {k: num(v) for k, v in self.values.items()},
            "matrices": {k: np.asarray(v, dtype=float).tolist() for k, v in self.matrices.items()},
            "note": self.note,
        }



def _cp():
    import cvxpy as cp

    return cp


def as_data(name: str, **arrays: Any) -> dict[str, np.ndarray]:
    """Arrays as 2-D floats; non-finite entries raise :class:`SolverError`.

    Parameters
    ----------
    name
        The LMI's name, for the message.
    **arrays
        The data matrices by name.
    """
    out = {}
    for key, value in arrays.items():
        a = np.atleast_2d(np.asarray(value, dtype=float))
        if not np.all(np.isfinite(a)):
            raise SolverError(f"{name}: data matrix {key} has non-finite entries (NaN or inf); nothing was solved")
        out[key] = a
    return out


def solve(problem, name: str) -> str:
    """Solve with Clarabel; return the status, or raise :class:`SolverError` for failures.

    Parameters
    ----------
    problem
        A :class:`cvxpy.Problem`.
    name
        The LMI's name, for the message.
    """
    cp = _cp()
    try:
        with warnings.catch_warnings():
            # "Solution may be inaccurate": handled by the numpy re-check, not by a warning.
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError as exc:
        raise SolverError(f"{name}: Clarabel failed ({exc})") from None
    except (ValueError, ArithmeticError) as exc:  # cvxpy rejects NaN parameters this way
        raise SolverError(f"{name}: problem data rejected ({exc})") from None
    status = problem.status
    if status in (cp.UNBOUNDED, cp.UNBOUNDED_INACCURATE):
        raise SolverError(f"{name}: problem is {status}; the LMI is mis-posed (missing normalisation)")
    if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE, cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        raise SolverError(f"{name}: Clarabel stopped with status {status!r}")
    return status


def solved(status: str) -> bool:
    """Whether ``status`` is one of cvxpy's optimal statuses (a solution to re-check)."""
    cp = _cp()
    return status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)


def cpsym(X):
    """Symmetric part of a cvxpy expression (PSD constraints need a symmetric argument)."""
    return 0.5 * (X + X.T)


def result_fail(name: str, status: str, data: dict[str, np.ndarray], note: str, tol: float, **kw: Any) -> LMIResult:
    """The answer "not certified": ``feasible=False``, no residuals, ``margin`` NaN."""
    return LMIResult(name=name, feasible=False, status=status, matrices=data, residuals={}, margin=float("nan"),
                     tolerance=tol, note=note, **kw)
