"""The interpolating cubic spline and the bracketed root finder the margin computations need, in numpy.

:func:`nniquad.analysis.margins.frd_crossings` interpolates a sampled frequency response by the parametric cubic
spline of FITPACK's ``splprep`` with ``s = 0`` and refines each crossover by ``brentq``.  Importing
``scipy.interpolate`` and ``scipy.optimize`` for those two calls is a third of a second of a cold ``nniquad verify``
(about a tenth of it), so both are written here:

* ``splprep(u=x, s=0, k=3)`` is the cubic spline through the samples with the interior knots ``x[2:-2]`` (FITPACK
  places the knots of an interpolating spline of odd degree at the inner data points), that is the cubic spline
  with **not-a-knot** end conditions; with fewer than 4 samples ``splprep`` uses the degree ``len(x) - 1``, which is
  the interpolating polynomial.  The weights ``splprep`` is given do not change an interpolating spline.
* ``brentq`` returns a point within ``xtol + rtol |x|`` of a sign change; bisection does the same.

``tests/test_interpolation.py`` compares both with scipy's own functions.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

__all__ = ["InterpolatingSpline", "bracketed_root"]


class InterpolatingSpline:
    """The cubic spline with not-a-knot end conditions through ``(x_i, y_i)`` (complex ``y`` allowed).

    Parameters
    ----------
    x : ndarray (n,)
        Strictly increasing abscissae, ``n >= 2``.
    y : ndarray (n,)
        Values at ``x``, real or complex.

    Notes
    -----
    Second derivatives ``M_i`` at the samples solve the usual continuity equations
    ``h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1} = 6 (δ_i - δ_{i-1})`` and, at ``x_1`` and ``x_{n-2}``,
    continuity of the third derivative (the not-a-knot condition): a banded system, solved once.  Outside
    ``[x_0, x_{n-1}]`` the end pieces are extended (as ``splev`` does by default).
    """

    def __init__(self, x: np.ndarray, y: np.ndarray) -> None:
        x = np.asarray(x, float)
        y = np.asarray(y)
        if x.ndim != 1 or y.shape != x.shape or x.size < 2 or not np.all(np.diff(x) > 0):
            raise ValueError("need at least 2 strictly increasing abscissae and one value at each")
        self.x, self.y = x, y.astype(complex) if np.iscomplexobj(y) else y.astype(float)
        self.h = np.diff(x)
        self.slope = np.diff(self.y) / self.h
        self.M = self._second_derivatives() if x.size > 3 else None

    def _second_derivatives(self) -> np.ndarray:
        import scipy.linalg as sla  # loaded anyway by the sampled-data analysis; not scipy.interpolate

        n, h, d = self.x.size, self.h, self.slope
        ab = np.zeros((5, n))  # LAPACK band storage: ab[2 + i - j, j] = A[i, j]
        i = np.arange(1, n - 1)
        ab[3, i - 1], ab[2, i], ab[1, i + 1] = h[i - 1], 2.0 * (h[i - 1] + h[i]), h[i]
        ab[2, 0], ab[1, 1], ab[0, 2] = h[1], -(h[0] + h[1]), h[0]
        ab[4, n - 3], ab[3, n - 2], ab[2, n - 1] = h[n - 2], -(h[n - 3] + h[n - 2]), h[n - 3]
        rhs = np.zeros(n, dtype=self.y.dtype)
        rhs[1:-1] = 6.0 * (d[1:] - d[:-1])
        if np.iscomplexobj(rhs):
            sol = sla.solve_banded((2, 2), ab, np.stack([rhs.real, rhs.imag], axis=1))
            return sol[:, 0] + 1j * sol[:, 1]
        return sla.solve_banded((2, 2), ab, rhs)

    def __call__(self, q: float | np.ndarray) -> np.ndarray:
        """The spline at ``q`` (any shape)."""
        q = np.asarray(q, float)
        x, y = self.x, self.y
        if self.M is None:  # 2 or 3 samples: the interpolating polynomial (Lagrange form)
            out = np.zeros(q.shape, dtype=y.dtype)
            for j in range(x.size):
                term = np.full(q.shape, y[j], dtype=y.dtype)
                for k in range(x.size):
                    if k != j:
                        term = term * (q - x[k]) / (x[j] - x[k])
                out = out + term
            return out
        i = np.clip(np.searchsorted(x, q, side="right") - 1, 0, x.size - 2)
        t, h, M = q - x[i], self.h[i], self.M
        return (y[i] + t * (self.slope[i] - h * (2.0 * M[i] + M[i + 1]) / 6.0) + t * t * M[i] / 2.0
                + t ** 3 * (M[i + 1] - M[i]) / (6.0 * h))


def bracketed_root(f: Callable[[float], float], a: float, b: float, xtol: float = 2e-12,
                   rtol: float = 4.0 * np.finfo(float).eps, max_iter: int = 200) -> float:
    """A point within ``xtol + rtol |x|`` of a sign change of ``f`` on ``[a, b]`` (bisection).

    Parameters
    ----------
    f
        A scalar function with ``f(a) f(b) <= 0``.
    a, b
        The bracket.
    xtol, rtol
        The absolute and relative width at which the bracket is taken as the root (``brentq``'s defaults).

    Raises
    ------
    ValueError
        ``f`` has the same strict sign at both ends, or a non-finite value at an end or inside.
    """
    fa, fb = float(f(a)), float(f(b))
    if not (math.isfinite(fa) and math.isfinite(fb)) or fa * fb > 0.0:
        raise ValueError("f must have a sign change on [a, b]")
    if fa == 0.0:
        return float(a)
    if fb == 0.0:
        return float(b)
    for _ in range(max_iter):
        m = 0.5 * (a + b)
        if abs(b - a) <= xtol + rtol * abs(m):
            return m
        fm = float(f(m))
        if not math.isfinite(fm):  # as brentq: a NaN inside the bracket is an error, not a direction
            raise ValueError(f"f is not finite at {m!r}")
        if fm == 0.0:
            return m
        if (fm < 0.0) == (fa < 0.0):
            a, fa = m, fm
        else:
            b = m
    return 0.5 * (a + b)
