"""Rounding constants of IEEE binary64 with rounding to nearest, and upward bounds built without directed rounding.

numpy offers no rounding-mode control, so an upper bound of a non-negative quantity is computed in round to
nearest and then inflated: a sum or a dot product of ``k`` non-negative terms computed in any order (with or
without fused multiply-adds) is at least ``(1 - γ_k)`` times the exact one (Higham, *Accuracy and Stability of
Numerical Algorithms*, §3.1), so multiplying by ``1 + 2γ_{k+2}`` and stepping one ulp up bounds it from above.
"""

from __future__ import annotations

import numpy as np

__all__ = ["UNIT_ROUNDOFF", "ETA", "gamma", "upward", "downward"]

#: Unit roundoff ``u = 2^-53`` of binary64 with rounding to nearest.
UNIT_ROUNDOFF: float = 2.0**-53
#: Smallest positive subnormal ``2^-1074``: the absolute error of an underflowing product.
ETA: float = 2.0**-1074


def gamma(k: int) -> float:
    """``γ_k = k u / (1 - k u)``: the relative error bound of ``k`` roundings (Higham, Lemma 3.1)."""
    ku = int(k) * UNIT_ROUNDOFF
    if not 0 <= ku < 0.5:
        raise ValueError(f"gamma({k}) is not defined for this dimension")
    return ku / (1.0 - ku)


def upward(x: np.ndarray | float, terms: int) -> np.ndarray | float:
    """An upper bound of a non-negative quantity computed as ``x`` with at most ``terms`` roundings to nearest.

    ``x (1 + 2γ_{terms+2} + 4u)`` plus ``(terms + 1) η`` for underflow: the extra ``4u`` covers the rounding of
    this product itself (``fl(xf) >= xf(1 - u)``), and adding a positive number never rounds below ``x``.
    Non-finite input stays non-finite (a bound of ``inf`` proves nothing, which is the safe answer).
    """
    x = np.asarray(x, dtype=float)
    out = x * (1.0 + 2.0 * gamma(terms + 2) + 4.0 * UNIT_ROUNDOFF) + (terms + 1) * ETA
    return float(out) if out.ndim == 0 else out


def downward(x: np.ndarray | float) -> np.ndarray | float:
    """``x`` stepped one ulp towards ``-inf``: below the exact value of a single operation rounded to nearest."""
    out = np.nextafter(np.asarray(x, dtype=float), -np.inf)
    return float(out) if out.ndim == 0 else out
