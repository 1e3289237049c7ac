"""The interpolating cubic spline and the bracketed root finder the margin computations need, in numpy.

:func:`nniquad.analysis.margins.frd_crossings` interpolates a sampled frequency response by the parametric cubic
spline of FITPACK's ``splprep`` with ``s = 0`` and refines each crossover by ``brentq``.  Importing
``scipy.interpolate`` and ``scipy.optimize`` for those two calls is a third of a second of a cold ``nniquad verify``
(about a tenth of it), so both are written here:

* ``splprep(u=x, s=0, k=3)`` is the cubic spline through the samples with the interior knots ``x[2:-2]`` (FITPACK
  places the knots of an interpolating spline of odd degree at the inner data points), that is the cubic spline
  with **not-a-knot** end conditions; with fewer than 4 samples ``splprep`` uses the degree ``len(x) - 1``, which is
  the interpolating polynomial.  The weights ``splprep`` is given do not change an interpolating spline.
* ``brentq`` returns a point within ``xtol + rtol |x|`` of a sign change; :func:`bracketed_root` is Brent's method
  too (secant and inverse quadratic steps, bisection when they do not shrink the bracket fast enough).

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
    """A point within ``xtol + rtol |x|`` of a sign change of ``f`` on ``[a, b]`` (Brent's method).

    Brent's algorithm (R. P. Brent, *Algorithms for Minimization without Derivatives*, 1973, ch. 4): the bracket
    ``[x, x_blk]`` around the sign change always holds it, and each step is a secant or inverse quadratic step from
    the best point when that step is short enough, else a bisection.  A smooth function takes about a quarter of
    the evaluations of pure bisection (the margins evaluate a 30-state frequency response at each), and the
    answer has the same guarantee.

    Parameters
    ----------
    f
        A scalar function with ``f(a) f(b) <= 0``.
    a, b
        The bracket.
    xtol, rtol
        The absolute and relative width at which the bracket is taken as the root (``brentq``'s defaults).
    max_iter
        Evaluations of ``f`` after the two ends; then the last point evaluated is returned.

    Raises
    ------
    ValueError
        ``f`` has the same strict sign at both ends, or a non-finite value at an end or inside.
    """
    x_pre, x_cur = float(a), float(b)
    f_pre, f_cur = float(f(a)), float(f(b))
    if not (math.isfinite(f_pre) and math.isfinite(f_cur)) or f_pre * f_cur > 0.0:
        raise ValueError("f must have a sign change on [a, b]")
    if f_pre == 0.0:
        return x_pre
    if f_cur == 0.0:
        return x_cur
    x_blk, f_blk = x_pre, f_pre  # the other end of the bracket: f_blk and f_cur have opposite signs
    step_pre = step_cur = x_cur - x_pre
    for _ in range(max_iter):
        if (f_pre < 0.0) != (f_cur < 0.0):  # the last step crossed the root: its start is the new other end
            x_blk, f_blk = x_pre, f_pre
            step_pre = step_cur = x_cur - x_pre
        if abs(f_blk) < abs(f_cur):  # keep the smaller residual as the current point
            x_pre, x_cur, x_blk = x_cur, x_blk, x_cur
            f_pre, f_cur, f_blk = f_cur, f_blk, f_cur
        tol = 0.5 * (xtol + rtol * abs(x_cur))
        half = 0.5 * (x_blk - x_cur)
        if f_cur == 0.0 or abs(half) < tol:
            return x_cur
        step_pre, step_cur = _brent_step(x_pre, x_cur, x_blk, f_pre, f_cur, f_blk, step_pre, step_cur, half, tol)
        x_pre, f_pre = x_cur, f_cur
        x_cur += step_cur if abs(step_cur) > tol else math.copysign(tol, half)
        f_cur = float(f(x_cur))
        if not math.isfinite(f_cur):  # as brentq: a NaN inside the bracket is an error, not a direction
            raise ValueError(f"f is not finite at {x_cur!r}")
    return x_cur


def _brent_step(x_pre: float, x_cur: float, x_blk: float, f_pre: float, f_cur: float, f_blk: float,
                step_pre: float, step_cur: float, half: float, tol: float) -> tuple[float, float]:
    """The next ``(previous step, step)`` of :func:`bracketed_root`: interpolation if it is safe, else bisection."""
    if abs(step_pre) > tol and abs(f_cur) < abs(f_pre):
        with np.errstate(all="ignore"):  # numpy floats: a zero or overflowing denominator is a nan, i.e. bisect
            if x_pre == x_blk:  # two points: the secant
                trial = -f_cur * (x_cur - x_pre) / np.float64(f_cur - f_pre)
            else:  # three points: inverse quadratic interpolation
                d_pre = (f_pre - f_cur) / np.float64(x_pre - x_cur)
                d_blk = (f_blk - f_cur) / np.float64(x_blk - x_cur)
                trial = -f_cur * (f_blk * d_blk - f_pre * d_pre) / (d_blk * d_pre * (f_blk - f_pre))
        if 2.0 * abs(trial) < min(abs(step_pre), 3.0 * abs(half) - tol):  # short enough: it shrinks the bracket
            return step_cur, float(trial)
    return half, half
