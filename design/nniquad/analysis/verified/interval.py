"""Midpoint-radius matrices that enclose an expression's exact value despite rounding.

An :class:`IMat` ``(mid, rad)`` stands for every real matrix ``X`` with ``|X - mid| <= rad`` entrywise.  Each
operation returns a midpoint computed in floating point and a radius that bounds, from above, both the
propagated radii and the rounding error of the midpoint (Rump, "Fast and parallel interval arithmetic", BIT 39,
1999, midpoint-radius products; here with round to nearest only, see
:func:`nniquad.analysis.verified.rounding.upward`).  Forming ``AᵀPA`` from exact float inputs this way yields a
matrix interval that contains the exact ``AᵀPA``: the input of Rump's Corollary 2.7.

Stacks ``(..., n, m)`` are supported throughout, so a grid of cells is enclosed in one call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nniquad.analysis.verified.rounding import ETA, UNIT_ROUNDOFF, gamma, upward

__all__ = ["IMat"]


@dataclass(frozen=True)
class IMat:
    """An interval matrix (or a stack of them) in midpoint-radius form.

    Attributes
    ----------
    mid : ndarray (..., n, m)
        The midpoint (a floating-point matrix).
    rad : ndarray (..., n, m)
        The radius, non-negative: the set is ``{X : |X - mid| <= rad}``.
    """

    mid: np.ndarray
    rad: np.ndarray

    @classmethod
    def point(cls, M: np.ndarray) -> "IMat":
        """The exact floating-point matrix ``M`` (radius 0)."""
        M = np.asarray(M, dtype=float)
        return cls(M, np.zeros_like(M))

    @classmethod
    def of(cls, x: "IMat | np.ndarray") -> "IMat":
        """``x`` itself if it is an :class:`IMat`, else the exact floating-point matrix ``x``."""
        return x if isinstance(x, IMat) else cls.point(np.asarray(x, dtype=float))

    @classmethod
    def around(cls, M: np.ndarray, radius: np.ndarray) -> "IMat":
        """``M ± radius`` (a stated uncertainty, e.g. the enclosure of a matrix over a parameter cell)."""
        M = np.asarray(M, dtype=float)
        r = np.broadcast_to(np.abs(np.asarray(radius, dtype=float)), M.shape).copy()
        return cls(M, r)

    @property
    def T(self) -> "IMat":
        """The transpose (exact)."""
        return IMat(np.swapaxes(self.mid, -1, -2), np.swapaxes(self.rad, -1, -2))

    def __add__(self, other: "IMat | np.ndarray") -> "IMat":
        o = IMat.of(other)
        mid = self.mid + o.mid
        return IMat(mid, upward(self.rad + o.rad + UNIT_ROUNDOFF * np.abs(mid), 3))

    def __neg__(self) -> "IMat":
        return IMat(-self.mid, self.rad)

    def __sub__(self, other: "IMat | np.ndarray") -> "IMat":
        return self + (-IMat.of(other))

    def scale(self, s: float) -> "IMat":
        """``s X`` for a floating-point scalar ``s`` (exact as given)."""
        s = float(s)
        mid = s * self.mid
        return IMat(mid, upward(abs(s) * self.rad + UNIT_ROUNDOFF * np.abs(mid), 3))

    def times(self, s: np.ndarray) -> "IMat":
        """Each matrix of a stack ``(k, n, m)`` times its own floating-point scalar ``s[i]`` (exact as given)."""
        s = np.asarray(s, dtype=float).reshape((-1,) + (1,) * (self.mid.ndim - 1))
        mid = s * self.mid
        return IMat(mid, upward(np.abs(s) * self.rad + UNIT_ROUNDOFF * np.abs(mid), 3))

    def divided(self, s: np.ndarray) -> "IMat":
        """Each matrix of a stack ``(k, n, m)`` divided by its own floating-point scalar ``s[i]`` (exact as given)."""
        s = np.asarray(s, dtype=float).reshape((-1,) + (1,) * (self.mid.ndim - 1))
        mid = self.mid / s
        return IMat(mid, upward(self.rad / np.abs(s) + UNIT_ROUNDOFF * np.abs(mid), 3))

    def diagonal_scaled(self, d: np.ndarray, e: np.ndarray) -> "IMat":
        """``diag(d) X diag(e)`` for powers of two ``d``, ``e`` (exact but for underflow, which costs at most η)."""
        d, e = np.asarray(d, float), np.asarray(e, float)
        return IMat(self.mid * d[..., :, None] * e[..., None, :],
                    self.rad * d[..., :, None] * e[..., None, :] + ETA)

    def __matmul__(self, other: "IMat | np.ndarray") -> "IMat":
        o = IMat.of(other)
        k = self.mid.shape[-1]
        mid = self.mid @ o.mid
        a, b = np.abs(self.mid), np.abs(o.mid)
        # |X Y - mid| <= |A| rY + rX (|B| + rY) + γ_k |A||B|: the propagated radius and the product's rounding
        rad = gamma(k) * (a @ b)
        if o.rad.any():
            rad = rad + a @ o.rad
        if self.rad.any():
            rad = rad + self.rad @ (b + o.rad)
        return IMat(mid, upward(rad, k + 4))

    def symmetric(self) -> "IMat":
        """``(X + Xᵀ)/2``; its midpoint is exactly symmetric (floating-point addition commutes)."""
        mid = (self.mid + np.swapaxes(self.mid, -1, -2)) * 0.5
        rad = 0.5 * (self.rad + np.swapaxes(self.rad, -1, -2)) + UNIT_ROUNDOFF * np.abs(mid)
        return IMat(mid, upward(rad, 3))  # symmetric too: a sum with its transpose, plus u|mid|

    def shift(self, c: float) -> "IMat":
        """``X - c I`` for a floating-point scalar ``c`` (on the last two axes, square)."""
        n = self.mid.shape[-1]
        eye = np.eye(n)
        mid = self.mid - c * eye
        rad = self.rad + eye * UNIT_ROUNDOFF * (np.abs(mid) + abs(float(c)))
        return IMat(mid, upward(rad, 3))

    def contains(self, X: np.ndarray) -> bool:
        """Whether the floating-point matrix ``X`` lies in the set (a test aid)."""
        return bool(np.all(np.abs(np.asarray(X, float) - self.mid) <= self.rad))
