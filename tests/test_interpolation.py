"""The numpy spline and root finder of the margins (nniquad.analysis.interpolation) against scipy's own functions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nniquad.analysis.interpolation import InterpolatingSpline, bracketed_root


def _response(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A loop-like frequency response with a delay, and noise so that no cubic fits it exactly."""
    return np.exp(-0.01j * w) / (1j * w * (1j * w + 1.0)) + 0.01 * (rng.normal(size=w.size) + 1j * rng.normal(size=w.size))


@pytest.mark.parametrize("n", [2, 3, 4, 5, 9, 60, 400])
def test_the_spline_is_splprep_with_s_0(n):
    """``splprep(u=w, s=0)`` / ``splev``, as ``frd_crossings`` called them, inside and beyond the samples."""
    from scipy.interpolate import splev, splprep

    rng = np.random.default_rng(n)
    w = np.sort(np.exp(rng.uniform(-3.0, 4.0, n)))
    r = _response(w, rng)
    tck, _ = splprep(u=w, x=[r.real, r.imag], w=1.0 / (np.abs(r) + 0.001), s=0.0, k=3 if n > 3 else n - 1)
    q = np.concatenate([np.exp(rng.uniform(np.log(w[0]), np.log(w[-1]), 500)), w, [0.9 * w[0], 1.1 * w[-1]]])
    re, im = splev(q, tck)
    got = InterpolatingSpline(w, r)(q)
    assert np.max(np.abs(got - (re + 1j * im))) <= 1e-9 * np.max(np.abs(r))
    np.testing.assert_allclose(InterpolatingSpline(w, r)(w), r, rtol=1e-12, atol=1e-14)


def test_the_spline_reproduces_a_cubic_exactly():
    """A not-a-knot cubic spline through samples of one cubic is that cubic (a derivation by hand: its third
    derivative is continuous at every knot, so it is one polynomial)."""
    x = np.array([0.0, 0.3, 1.0, 1.1, 2.5, 4.0])
    p = np.array([0.5, -1.0, 2.0, 0.25])
    q = np.linspace(-0.5, 4.5, 101)
    np.testing.assert_allclose(InterpolatingSpline(x, np.polyval(p, x))(q), np.polyval(p, q), rtol=1e-11, atol=1e-11)


def test_bad_abscissae_are_refused():
    with pytest.raises(ValueError):
        InterpolatingSpline(np.array([0.0, 1.0, 1.0]), np.zeros(3))
    with pytest.raises(ValueError):
        InterpolatingSpline(np.array([0.0]), np.zeros(1))


@pytest.mark.parametrize("f, a, b, root", [
    (lambda x: x * x - 2.0, 0.0, 3.0, math.sqrt(2.0)),
    (lambda x: math.cos(x), 1.0, 2.0, math.pi / 2),
    (lambda x: math.exp(x) - 10.0, -5.0, 5.0, math.log(10.0)),
    (lambda x: x ** 3 - x - 1.0, 1.0, 2.0,  # the plastic number, by Cardano's formula
     ((9 + math.sqrt(69)) / 18) ** (1 / 3) + ((9 - math.sqrt(69)) / 18) ** (1 / 3)),
])
def test_the_root_is_brentq_s_within_its_tolerance(f, a, b, root):
    from scipy.optimize import brentq

    got = bracketed_root(f, a, b)
    assert abs(got - root) <= 2e-12 + 4 * np.finfo(float).eps * abs(root)
    assert abs(got - brentq(f, a, b)) <= 4e-12


def test_a_bracket_without_a_sign_change_is_refused():
    with pytest.raises(ValueError):
        bracketed_root(lambda x: x * x + 1.0, -1.0, 1.0)
    with pytest.raises(ValueError):  # a NaN inside the bracket, as brentq refuses it
        bracketed_root(lambda x: x - 1.5 if abs(x - 1.5) > 0.1 else math.nan, 1.0, 2.0)
    assert bracketed_root(lambda x: x - 1.0, 1.0, 2.0) == 1.0  # a root at an end is returned as it is


@pytest.mark.parametrize("f, a, b, root, most", [
    (lambda x: math.cos(x), 1.0, 2.0, math.pi / 2, 10),  # smooth: interpolation steps, a few evaluations
    (lambda x: (x - 0.3) ** 9, -1.0, 2.0, 0.3, 130),  # flat at a ninefold root: interpolation crawls, bisection rescues
    (lambda x: -1.0 if x < 0.7 else 1.0, 0.0, 1.0, 0.7, 45),  # a jump: nothing to interpolate, bisection alone (41)
])
def test_brent_steps_shrink_the_bracket_and_keep_the_root_inside(f, a, b, root, most):
    """Brent's method against its two failure modes: a step that leaves the bracket (the root is always kept) and
    interpolation that stalls (bisection takes over, so the evaluations stay within 3x of bisection's 41-43)."""
    calls = []

    def counted(x):
        calls.append(x)
        return f(x)

    got = bracketed_root(counted, a, b)
    assert abs(got - root) <= 2e-12 + 4 * np.finfo(float).eps * abs(root)
    assert all(a <= x <= b for x in calls)
    assert len(calls) <= most, len(calls)
