"""The interpolating cubic spline of sampled data, with the not-a-knot end conditions.

:func:`nniquad.analysis.margins.frd_crossings` refines crossovers on a spline
through a sampled frequency response.  It is the spline FITPACK builds with
``scipy.interpolate.splprep(..., s=0)`` (cubic, knots at every interior sample
but the second and the second-to-last: the not-a-knot spline, the unique
interpolant of that space), written here in numpy so that ``verify`` does not
import ``scipy.interpolate`` (a quarter of a second of a cold start).
``tests/test_margins.py`` compares the two.

The spline is stored in Hermite form: the samples ``y_i`` and the slopes
``s_i`` at the abscissae.  The slopes solve one tridiagonal system; on
``[x_i, x_{i+1}]`` with ``h_i = x_{i+1} - x_i`` and ``δ_i = (y_{i+1} - y_i)/h_i``,

* a continuous second derivative at an interior sample ``x_i`` reads
  ``h_i s_{i-1} + 2 (h_{i-1} + h_i) s_i + h_{i-1} s_{i+1} = 3 (h_i δ_{i-1} + h_{i-1} δ_i)``;
* a continuous third derivative at ``x_1`` (the first cubic and the second
  are one polynomial) reads, after the second-derivative row at ``x_1`` is used
  to eliminate ``s_2``,
  ``h_1 s_0 + (h_0 + h_1) s_1 = ((h_0 + 2 (h_0 + h_1)) h_1 δ_0 + h_0² δ_1) / (h_0 + h_1)``,
  and likewise at ``x_{n-2}``.

Three samples give the parabola through them, two the straight line (as FITPACK's
spline of degree ``n - 1``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["NotAKnotSpline"]


class NotAKnotSpline:
    """Interpolating cubic spline (not-a-knot) of real or complex samples.

    Parameters
    ----------
    x : ndarray
        Strictly increasing abscissae, at least 2.
    y : ndarray
        Samples at ``x`` (real or complex).

    Examples
    --------
    A cubic is reproduced exactly (it is its own not-a-knot spline):

    >>> import numpy as np
    >>> x = np.array([0.0, 0.5, 1.5, 2.0, 3.5])
    >>> s = NotAKnotSpline(x, x**3 - 2 * x)
    >>> bool(np.isclose(s(1.0), -1.0))
    True
    """

    def __init__(self, x: np.ndarray, y: np.ndarray) -> None:
        x = np.asarray(x, float)
        y = np.asarray(y)
        if x.ndim != 1 or x.size < 2 or y.shape != x.shape:
            raise ValueError("a spline needs at least 2 abscissae and one sample at each")
        h = np.diff(x)
        if not np.all(h > 0):
            raise ValueError("the abscissae of a spline must increase strictly")
        self.x, self.y, self.h = x, y, h
        self.slopes = self._slopes(x, y, h)

    @staticmethod
    def _slopes(x: np.ndarray, y: np.ndarray, h: np.ndarray) -> np.ndarray:
        d = np.diff(y) / h
        n = x.size
        if n == 2:
            return np.array([d[0], d[0]])
        if n == 3:  # the parabola y_0 + δ_0 (t - x_0) + c (t - x_0)(t - x_1)
            c = (d[1] - d[0]) / (x[2] - x[0])
            return d[0] + c * (2.0 * x - x[0] - x[1])
        from scipy.linalg import solve_banded  # scipy.linalg is loaded anyway (the matrix exponentials)

        ab = np.zeros((3, n))  # rows: super-, main and sub-diagonal (solve_banded's layout)
        rhs = np.empty(n, dtype=np.result_type(d, float))
        ab[1, 1:-1] = 2.0 * (h[:-1] + h[1:])
        ab[0, 2:] = h[:-1]
        ab[2, :-2] = h[1:]
        rhs[1:-1] = 3.0 * (h[1:] * d[:-1] + h[:-1] * d[1:])
        first, last = h[0] + h[1], h[-1] + h[-2]
        ab[1, 0], ab[0, 1] = h[1], first
        rhs[0] = ((h[0] + 2.0 * first) * h[1] * d[0] + h[0] ** 2 * d[1]) / first
        ab[1, -1], ab[2, -2] = h[-2], last
        rhs[-1] = (h[-1] ** 2 * d[-2] + (2.0 * last + h[-1]) * h[-2] * d[-1]) / last
        return solve_banded((1, 1), ab, rhs)

    def __call__(self, t: Any) -> Any:
        """The spline at ``t`` (scalar or array; beyond the ends, the end cubics continued)."""
        t_arr = np.asarray(t, float)
        i = np.clip(np.searchsorted(self.x, t_arr, side="right") - 1, 0, self.x.size - 2)
        h = self.h[i]
        u = (t_arr - self.x[i]) / h
        v = 1.0 - u
        out = ((1.0 + 2.0 * u) * v * v * self.y[i] + u * v * v * h * self.slopes[i]
               + u * u * (3.0 - 2.0 * u) * self.y[i + 1] - u * u * v * h * self.slopes[i + 1])
        return out if np.ndim(t) else out[()]
