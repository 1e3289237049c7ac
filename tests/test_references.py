"""References: closed forms, derivatives (analytic and by finite differences), minimum-jerk boundary conditions,
and the one-line errors of the spec and file parsers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nniquad.control.reference_files import parse_reference
from nniquad.control.references import Circle, FigureEight, MinimumJerk, SetpointSteps, TimeShifted
from nniquad.errors import InputError

SQUARE = MinimumJerk((0.0, 4.0, 5.0, 9.0), ((0.0, 0.0), (2.0, 0.0), (2.0, 0.0), (2.0, 2.0)))
REFERENCES = [Circle(1.5, 6.0), FigureEight(2.0, 1.0, 8.0), SQUARE, TimeShifted(FigureEight(2.0, 1.0, 8.0), 1.3)]


def test_closed_forms():
    t = np.linspace(0, 10, 37)
    w = 2 * math.pi / 6.0
    np.testing.assert_allclose(Circle(1.5, 6.0).position(t), np.c_[1.5 * np.cos(w * t), 1.5 * np.sin(w * t)],
                               atol=1e-15)
    w = 2 * math.pi / 8.0
    np.testing.assert_allclose(FigureEight(2.0, 1.0, 8.0).position(t), np.c_[2 * np.sin(w * t), np.sin(2 * w * t)],
                               atol=1e-15)
    # circle: speed R ω and centripetal acceleration R ω² towards the centre
    p, v, a = Circle(1.5, 6.0).sample(t)
    w = 2 * math.pi / 6.0
    np.testing.assert_allclose(np.hypot(*v.T), 1.5 * w)
    np.testing.assert_allclose(a, -w**2 * p, atol=1e-14)


@pytest.mark.parametrize("ref", REFERENCES, ids=lambda r: type(r).__name__)
def test_derivatives_are_those_of_the_position(ref):
    """Velocity, acceleration and jerk against central differences of the position, velocity and acceleration."""
    h = 1e-4
    t = np.linspace(0.05, 8.9, 211)
    t = t[np.all(np.abs(t[:, None] - np.array([0.0, 4.0, 5.0, 9.0])[None]) > 2 * h, axis=1)]  # off the leg joins
    p, v, a = ref.sample(t)
    fd = lambda f: (f(t + h) - f(t - h)) / (2 * h)  # noqa: E731
    np.testing.assert_allclose(v, fd(ref.position), atol=1e-6)
    np.testing.assert_allclose(a, fd(lambda s: ref.sample(s)[1]), atol=1e-6)
    np.testing.assert_allclose(ref.jerk(t), fd(lambda s: ref.sample(s)[2]), atol=1e-5)


def test_minimum_jerk_boundary_conditions_and_shape():
    times, points = np.array(SQUARE.times), np.array(SQUARE.points)
    p, v, a = SQUARE.sample(times)
    np.testing.assert_allclose(p, points, atol=1e-15)
    assert np.all(v == 0) and np.all(a == 0)  # at rest with zero acceleration at every waypoint
    # s(1/2) = 1/2, peak speed 15/8 L/T at mid-leg, s'' = 0 at mid-leg; held before the start and after the end
    p, v, a = SQUARE.sample([2.0, 7.0])
    np.testing.assert_allclose(p, [[1.0, 0.0], [2.0, 1.0]], atol=1e-15)
    np.testing.assert_allclose(np.hypot(*v.T), 15 / 8 * 2.0 / 4.0)
    np.testing.assert_allclose(a, 0.0, atol=1e-15)
    p, v, a = SQUARE.sample([-1.0, 4.5, 20.0])
    np.testing.assert_allclose(p, [[0, 0], [2, 0], [2, 2]])
    assert np.all(v == 0) and np.all(a == 0)


def test_setpoint_steps():
    ref = SetpointSteps((0.0, 2.0), ((1.0, 0.0), (0.0, -1.0)))
    p, v, a = ref.sample([-1.0, 0.0, 1.999, 2.0, 5.0])
    np.testing.assert_array_equal(p, [[1, 0], [1, 0], [1, 0], [0, -1], [0, -1]])
    assert not np.any(v) and not np.any(a)


def test_specs():
    c = parse_reference("circle:1.5,6")
    assert c == Circle(1.5, 6.0, spec="circle:1.5,6")
    assert parse_reference("figure8:2,1,8") == FigureEight(2.0, 1.0, 8.0, spec="figure8:2,1,8")


@pytest.mark.parametrize("spec, words", [
    ("circle:1", "takes 2 numbers"), ("figure8:1,2", "takes 3 numbers"), ("circle:-1,4", "radius"),
    ("circle:1,nan", "period"), ("square:1", "expected"), ("", "expected"), ("path/without.suffix", "expected"),
])
def test_bad_specs_are_one_line_errors(spec, words):
    with pytest.raises(InputError, match=words) as err:
        parse_reference(spec)
    assert "\n" not in str(err.value)


def test_csv_waypoints(tmp_path):
    f = tmp_path / "wp.csv"
    f.write_text("t,x,y\n0,0,0\n4,2,0\n5,2,0\n9,2,2\n")
    ref = parse_reference(str(f))
    assert ref.times == SQUARE.times and ref.points == SQUARE.points
    for text, words in [("x,y\n0,0\n", "header t,x,y"), ("t,x,y\n0,0\n", "line 2: expected 3 fields"),
                        ("t,x,y\n0,0,zero\n", "line 2: y"), ("t,x,y\n", "no waypoint"),
                        ("t,x,y\n0,0,0\n0,1,1\n", "times must increase")]:
        f.write_text(text)
        with pytest.raises(InputError, match=words) as err:
            parse_reference(str(f))
        assert "\n" not in str(err.value)
    with pytest.raises(InputError):
        parse_reference(str(tmp_path / "missing.csv"))


def test_toml_waypoints_with_cruise_speed_and_holds(tmp_path):
    f = tmp_path / "wp.toml"
    f.write_text("points = [[0, 0], [2, 0], [2, 2]]\ncruise_speed_m_s = 0.5\nhold_s = 1.0\n")
    ref = parse_reference(str(f))
    # each 2 m leg lasts 2/0.5 = 4 s, the middle waypoint is held 1 s: the square's schedule
    assert ref.times == SQUARE.times and ref.points == SQUARE.points
    f.write_text('points = [[0, 0], [1, 1]]\ntimes = [0, 2]\nkind = "steps"\n')
    assert parse_reference(str(f)) == SetpointSteps((0.0, 2.0), ((0.0, 0.0), (1.0, 1.0)), spec=str(f))
    for text, words in [("points = [[0, 0]]\n", "either times or cruise_speed_m_s"),
                        ("points = [[0, 0], [1, 1]]\ntimes = [0, 1]\ncruise_speed_m_s = 1\n", "either"),
                        ("points = [[0, 0]]\ntimes = [0]\nspeed = 1\n", "unknown key 'speed'"),
                        ("points = [[0]]\ntimes = [0]\n", "pairs"),
                        ('points = [[0, 0]]\ntimes = [0]\nkind = "spline"\n', "kind"),
                        ("points = [[0, 0], [1, 0]]\ncruise_speed_m_s = 0\n", "cruise_speed_m_s"),
                        ("points = [[0, 0]\n", "not valid TOML")]:
        f.write_text(text)
        with pytest.raises(InputError, match=words) as err:
            parse_reference(str(f))
        assert "\n" not in str(err.value)


def test_time_shift():
    base = FigureEight(2.0, 1.0, 8.0)
    shifted = TimeShifted(base, 3.0)
    t = np.linspace(0, 5, 11)
    for mine, theirs in zip(shifted.sample(t), base.sample(t + 3.0)):
        np.testing.assert_array_equal(mine, theirs)
