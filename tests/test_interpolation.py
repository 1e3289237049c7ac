"""The not-a-knot spline of ``frd_crossings``, against FITPACK (``scipy.interpolate.splprep``, ``s = 0``),
against polynomials it must reproduce exactly, and on bad input."""

from __future__ import annotations

import numpy as np
import pytest

from nniquad.analysis.interpolation import NotAKnotSpline


@pytest.mark.parametrize("n", [2, 3, 4, 5, 8, 300])
def test_the_spline_is_fitpacks_interpolating_spline(n):
    """What python-control's FRD margins interpolate with: splprep's parametric spline through Re and Im, s = 0
    (degree n - 1 below four samples), with its weights."""
    from scipy.interpolate import splev, splprep

    rng = np.random.default_rng(n)
    x = np.cumsum(rng.uniform(0.05, 1.0, n))
    y = rng.normal(size=n) + 1j * rng.normal(size=n)
    tck, _ = splprep(u=x, x=[y.real, y.imag], w=1.0 / (np.abs(y) + 0.001), s=0.0, k=min(3, n - 1))
    t = np.linspace(x[0], x[-1], 1001)
    re, im = splev(t, tck)
    spline = NotAKnotSpline(x, y)
    np.testing.assert_allclose(spline(t), re + 1j * im, rtol=0, atol=1e-12 * np.max(np.abs(y)))
    np.testing.assert_allclose(spline(x), y, rtol=0, atol=1e-14 * np.max(np.abs(y)))  # it interpolates
    assert isinstance(spline(float(x[1])), complex)  # a scalar in, a scalar out


def test_a_cubic_and_a_parabola_are_their_own_splines():
    """A cubic is the not-a-knot spline of its samples (any spacing); three samples give their parabola."""
    x = np.array([-1.0, -0.2, 0.1, 0.9, 2.5, 3.0])
    cubic = lambda t: 2 * t**3 - t**2 + 0.5 * t - 4  # noqa: E731
    t = np.linspace(-1.5, 3.5, 97)  # beyond the ends too: the end cubics continued
    np.testing.assert_allclose(NotAKnotSpline(x, cubic(x))(t), cubic(t), rtol=0, atol=1e-11)
    parabola = lambda t: 3 * t**2 - 2 * t + 1  # noqa: E731
    np.testing.assert_allclose(NotAKnotSpline(x[:3], parabola(x[:3]))(t), parabola(t), rtol=0, atol=1e-11)
    # and not every curve is: sin is only approximated (the comparison above can fail)
    assert np.max(np.abs(NotAKnotSpline(x, np.sin(x))(t) - np.sin(t))) > 1e-4


@pytest.mark.parametrize("x, y", [([1.0], [1.0]), ([0.0, 1.0], [1.0]), ([0.0, 0.0, 1.0], [1.0, 2.0, 3.0]),
                                  ([0.0, 2.0, 1.0], [1.0, 2.0, 3.0])])
def test_bad_abscissae_are_refused(x, y):
    with pytest.raises(ValueError, match="abscissae"):
        NotAKnotSpline(np.array(x), np.array(y))
