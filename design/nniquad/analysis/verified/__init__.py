"""Proofs of matrix inequalities in floating point, and their exact rational counterpart.

* :mod:`~nniquad.analysis.verified.rounding`: the unit roundoff, ``γ_k`` and upward-rounded bounds computed with
  round-to-nearest only.
* :mod:`~nniquad.analysis.verified.interval`: midpoint-radius matrices whose radius encloses every rounding error
  of forming an expression (and any stated uncertainty), so that the exact expression lies inside.
* :mod:`~nniquad.analysis.verified.spd`: Rump's verified positive-definiteness test (BIT 46, 2006,
  Corollaries 2.4 and 2.7), with three outcomes: ``proven``, ``fails`` (a vector whose quadratic form is
  proven non-positive), ``not proven``.
* :mod:`~nniquad.analysis.verified.exact`: the same question decided in exact rational arithmetic (an LDLᵀ
  over :class:`fractions.Fraction`), for the small matrices of the reduced loop.
"""

from nniquad.analysis.verified.exact import exact_definite, fraction_matrix
from nniquad.analysis.verified.interval import IMat
from nniquad.analysis.verified.spd import FAILS, NOT_PROVEN, PROVEN, Proof, prove_definite, prove_definite_batch

__all__ = ["IMat", "Proof", "PROVEN", "FAILS", "NOT_PROVEN", "prove_definite", "prove_definite_batch",
           "exact_definite", "fraction_matrix"]
