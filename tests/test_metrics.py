"""Metrics against hand-made signals whose answers are known in closed form."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from nniquad.errors import NniquadError, SimulationError
from nniquad.sim.metrics import overshoot_pct, overshoot_pct_batch, peak_abs, peak_tilt_deg, rms_after, settling_time, settling_time_batch, tilt_deg, time_on_limit_fraction
from nniquad.sim.verdicts import Metrics, compute_metrics, diverged, diverged_batch

E0 = np.array([2.0, -1.5]) / 2.5  # paper's initial direction
E_PERP = np.array([-E0[1], E0[0]])


def along(d: np.ndarray, direction: np.ndarray = E0) -> np.ndarray:
    return np.outer(d, direction)


def from_distances(d) -> np.ndarray:
    return along(np.asarray(d, dtype=float))


# --------------------------------------------------------------------- settling


def test_settling_of_exponential_decay_is_ln50():
    # ‖ξ‖ = 2.5 e^{-t} meets the 0.05 m band at t = ln(2.5/0.05) = ln 50.
    h = 1e-3
    t = np.arange(0.0, 8.0 + h / 2, h)
    ts = settling_time(t, along(2.5 * np.exp(-t)))
    # The distance is convex, so the chord lies above it and the interpolated
    # crossing is late, by at most h²/8 · max|d''| / min|d'| = h²/8 · e^h.
    err = ts - math.log(50.0)
    assert 0.0 <= err <= h**2 / 8 * math.exp(h)


def test_settling_counts_the_last_exit():
    # Inside at t=1, out again at t=2 (0.07 m), back in at t=3: the crossing
    # between t=2 and t=3 is at 2 + (0.07-0.05)/(0.07-0.03) = 2.5 s.
    t = np.arange(6.0)
    xy = from_distances([2.5, 0.03, 0.07, 0.03, 0.01, 0.0])
    assert settling_time(t, xy) == pytest.approx(2.5, abs=1e-12)


def test_run_ending_outside_the_band_did_not_settle():
    t = np.linspace(0.0, 1.0, 11)
    assert settling_time(t, along(2.5 * np.exp(-t))) is None


def test_never_outside_settles_at_zero():
    t = np.linspace(0.0, 1.0, 11)
    xy = along(0.01 * np.ones_like(t))
    assert settling_time(t, xy, reference_norm=2.5) == 0.0


def test_non_finite_sample_counts_as_outside():
    t = np.arange(5.0)
    xy = from_distances([2.5, 0.01, np.nan, 0.01, 0.0])
    assert settling_time(t, xy) == 3.0


def test_band_fraction_and_reference_norm():
    h = 1e-3
    t = np.arange(0.0, 8.0 + h / 2, h)
    xy = along(2.5 * np.exp(-t))
    assert settling_time(t, xy, band_fraction=0.05) == pytest.approx(math.log(20.0), abs=1e-6)
    assert settling_time(t, xy, reference_norm=5.0) == pytest.approx(math.log(25.0), abs=1e-6)


def test_batch_matches_scalar_and_flags_unsettled_with_nan():
    t = np.linspace(0.0, 8.0, 801)
    runs = np.stack(
        [
            along(2.5 * np.exp(-t)),
            along(2.5 * np.exp(-2 * t) * np.cos(3 * t), E_PERP),
            along(2.5 * np.exp(-0.1 * t)),  # still outside at 8 s
        ]
    )
    batch = settling_time_batch(t, runs)
    assert batch.shape == (3,)
    for k in range(2):
        assert batch[k] == pytest.approx(settling_time(t, runs[k]), abs=1e-15)
    assert math.isnan(batch[2])


# -------------------------------------------------------------------- overshoot


def test_overshoot_of_damped_step_response_matches_closed_form():
    # x(t) = D e^{-σt}(cos ωt + σ/ω sin ωt) starts at rest at D; its first
    # minimum is at t = π/ω with value -D e^{-σπ/ω}: overshoot 100 e^{-ζπ/√(1-ζ²)} %.
    zeta, wn, D = 0.3, 2.0, 2.5
    sigma, w = zeta * wn, wn * math.sqrt(1 - zeta**2)
    t = np.arange(0.0, 10.0, 1e-4)
    x = D * np.exp(-sigma * t) * (np.cos(w * t) + sigma / w * np.sin(w * t))
    y = 0.5 * np.exp(-sigma * t) * np.sin(w * t)  # across the initial line: must not count
    xy = along(x) + along(y, E_PERP)
    expected = 100.0 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
    # Sampling misses the peak by at most |x''| (h/2)² / 2 ~ 1e-8 m, i.e. < 1e-6 %.
    assert overshoot_pct(t, xy) == pytest.approx(expected, abs=1e-6)


def test_overshoot_is_zero_for_monotone_decay():
    t = np.linspace(0.0, 5.0, 501)
    assert overshoot_pct(t, along(2.5 * np.exp(-t))) == 0.0


def test_overshoot_batch_and_undefined_cases():
    t = np.linspace(0.0, 1.0, 3)
    runs = np.stack([from_distances([2.5, -0.25, 0.0]), from_distances([2.5, np.nan, 0.0])])
    out = overshoot_pct_batch(t, runs)
    assert out[0] == pytest.approx(10.0)
    assert math.isnan(out[1])
    with pytest.raises(SimulationError):
        overshoot_pct(t, from_distances([0.0, 1.0, 0.0]))


# ------------------------------------------------------------------------- tilt


def test_tilt_of_pure_roll_or_pitch_equals_that_angle():
    angles = np.array([1e-7, 0.01, 0.3, 1.0])
    assert np.allclose(tilt_deg(angles, 0.0), np.degrees(angles), rtol=1e-12, atol=0)
    assert np.allclose(tilt_deg(0.0, -angles), np.degrees(angles), rtol=1e-12, atol=0)


def test_tilt_of_equal_roll_and_pitch():
    a = math.radians(30.0)
    assert tilt_deg(a, a) == pytest.approx(math.degrees(math.acos(0.75)), abs=1e-12)
    # Generic pair against the defining arccos form (fine away from zero).
    phi, theta = 0.4, -0.7
    assert tilt_deg(phi, theta) == pytest.approx(math.degrees(math.acos(math.cos(phi) * math.cos(theta))), abs=1e-10)


def test_peak_tilt():
    phi = np.radians([0.0, 10.0, 20.0, 5.0])
    assert peak_tilt_deg(phi, np.zeros(4)) == pytest.approx(20.0, abs=1e-12)


# ---------------------------------------------------------------- other signals


def test_time_on_limit_fraction_of_ramp_then_hold():
    # 30 t for t < 1, then held at 30 until t = 2: at the limit half the time,
    # give or take the rel_tol window (1 ms here) and half a sample.
    t = np.linspace(0.0, 2.0, 2001)
    v = 30.0 * np.minimum(t, 1.0)
    assert time_on_limit_fraction(t, v, 30.0) == pytest.approx(0.5, abs=1e-3)
    assert time_on_limit_fraction(t, -v, 30.0) == pytest.approx(0.5, abs=1e-3)
    assert time_on_limit_fraction(t, 0.5 * v, 30.0) == 0.0


def test_rms_after_of_sine_over_whole_periods():
    t = np.linspace(0.0, 4.0, 40001)
    s = np.where(t < 2.0, 10.0, 0.0) + 3.0 * np.sin(2 * np.pi * t)
    assert rms_after(t, s, 2.0) == pytest.approx(3.0 / math.sqrt(2.0), rel=1e-6)
    assert rms_after(t, 1.0 + s, 2.0, remove_mean=True) == pytest.approx(3.0 / math.sqrt(2.0), rel=1e-6)
    assert rms_after(t, s, None) is None
    assert rms_after(t, s, 5.0) is None


def test_peak_abs():
    assert peak_abs([[1.0, -4.0], [2.0, 3.0]]) == 4.0


def test_divergence_detection():
    xy = along(2.5 * np.exp(-np.linspace(0, 1, 5)))
    assert not diverged(xy)
    bad = xy.copy()
    bad[3, 0] = np.nan
    assert diverged(bad)
    far = xy.copy()
    far[2] = [300.0, 0.0]  # beyond 100 × 2.5 m
    assert diverged(far)
    assert not diverged(far, threshold_m=1e3)
    inf = xy.copy()
    inf[4, 1] = np.inf
    assert diverged_batch(np.stack([xy, bad, far, inf])).tolist() == [False, True, True, True]


# ----------------------------------------------------------------------- bundle


def test_compute_metrics_fills_what_it_can():
    t = np.linspace(0.0, 10.0, 10001)
    xy = along(2.5 * np.exp(-t))
    phi = np.radians(5.0) * np.exp(-t) * np.cos(t)
    theta = np.zeros_like(t)
    cmd = np.minimum(40.0 * np.exp(-t), 30.0)
    rotors = np.column_stack([np.full_like(t, 600.0 + k) for k in range(4)])
    z = 0.02 * np.sin(t)
    m = compute_metrics(t, xy, phi=phi, theta=theta, cmd_tilt_deg=cmd, rotor_speeds=rotors, z=z, z_ref=0.0)
    assert m.settling_s == pytest.approx(math.log(50.0), abs=1e-6)
    assert m.overshoot_pct == 0.0
    assert m.peak_tilt_deg == pytest.approx(5.0, abs=1e-9)
    assert m.peak_cmd_tilt_deg == 30.0
    # cmd = 30 while 40 e^{-t} >= 30·(1-1e-3), i.e. t <= ln(40/29.97) ≈ 0.2887 s.
    assert m.tilt_limit_fraction == pytest.approx(math.log(40 / 29.97) / 10.0, abs=1e-3)
    assert m.peak_rotor_speed_rad_s == 603.0
    assert m.altitude_dev_m == pytest.approx(0.02, abs=1e-8)
    assert m.tilt_jitter_rms_deg is not None and 0.0 < m.tilt_jitter_rms_deg < 5.0 * 0.02
    assert m.diverged is False
    assert m.horizon_s == 10.0
    assert Metrics.from_json(m.to_json()) == m


def test_compute_metrics_without_optional_signals_and_json_nulls():
    t = np.linspace(0.0, 1.0, 101)
    xy = along(2.5 * np.exp(-t))
    m = compute_metrics(t, xy)
    data = m.to_json()
    assert data["settling_s"] is None  # still outside the band at 1 s
    assert data["peak_tilt_deg"] is None and data["tilt_limit_fraction"] is None
    json.dumps(data, allow_nan=False)
    xy_bad = xy.copy()
    xy_bad[50] = np.nan
    m_bad = compute_metrics(t, xy_bad)
    assert m_bad.diverged and m_bad.settling_s is None and m_bad.overshoot_pct is None


def test_shape_errors_are_programming_errors_not_user_errors():
    """A wrong array shape can only come from calling code: ValueError, never the CLI's one-line user error."""
    t = np.linspace(0.0, 1.0, 5)
    for call in (lambda: settling_time(t, np.zeros((4, 2))), lambda: settling_time(t[::-1], np.ones((5, 2))),
                 lambda: settling_time_batch(t, np.ones((5, 2)))):
        with pytest.raises(ValueError) as info:
            call()
        assert not isinstance(info.value, NniquadError)


def test_overshoot_is_measured_along_the_start_direction_with_a_sideways_offset_at_the_peak():
    """At the overshoot peak the run is 1.2 m to the side: only the component along e0 counts.

    The distance past the origin at the peak is hypot(along, sideways), 61 % of
    ‖ξ(0)‖ against 37 % along e0: an implementation that measures that distance fails.
    """
    zeta, wn, D = 0.3, 2.0, 2.5
    sigma, w = zeta * wn, wn * math.sqrt(1 - zeta**2)
    t = np.arange(0.0, 10.0, 1e-4)
    x = D * np.exp(-sigma * t) * (np.cos(w * t) + sigma / w * np.sin(w * t))
    y = 1.5 * (1.0 - np.exp(-t))  # sideways drift, 1.5 (1 - e^{-π/ω}) ≈ 1.2 m at the peak t = π/ω
    t_peak = math.pi / w
    side_at_peak = 1.5 * (1.0 - math.exp(-t_peak))
    along_at_peak = D * math.exp(-sigma * t_peak)
    expected = 100.0 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
    got = overshoot_pct(t, along(x) + along(y, E_PERP))
    assert got == pytest.approx(expected, abs=1e-6)
    # the wrong measure (distance past the origin) would be this much larger
    assert 100.0 * math.hypot(along_at_peak, side_at_peak) / D > expected + 20.0
    # the batch form agrees, also when the run's own start direction is not the paper's
    rot = np.array([[0.0, -1.0], [1.0, 0.0]])
    xy_rot = (along(x) + along(y, E_PERP)) @ rot.T
    assert overshoot_pct_batch(t, xy_rot[None])[0] == pytest.approx(expected, abs=1e-6)


# ------------------------------------------------------------------ divergence and altitude loss


def test_divergence_scale_threshold_and_non_finite_altitude():
    t = np.linspace(0.0, 1.0, 3)
    xy = from_distances([2.5, 200.0, 1.0])  # 80 x the start: not diverged at factor 100
    assert not diverged(xy)
    assert diverged(from_distances([2.5, 251.0, 1.0]))  # beyond 100 x 2.5 m
    # an explicit scale (Monte Carlo: max(start distance, band)) replaces the start distance
    assert diverged(xy, scale_m=1.0) and not diverged(xy, scale_m=3.0)
    assert diverged(from_distances([0.0, 101.0, 0.0]))  # a run from the origin: 1 m scale
    assert diverged(xy, z=np.array([0.0, np.nan, 0.0]))  # a non-finite altitude blows the run up too
    flags = diverged_batch(np.stack([xy, from_distances([2.5, 251.0, 0.0])]), z_batch=np.zeros((2, 3)))
    assert flags.tolist() == [False, True]
    assert t.size == 3


def test_altitude_loss_and_the_one_failure_verdict():
    from nniquad.sim.verdicts import altitude_lost_batch, failure_reason
    from nniquad.config import ALTITUDE_LIMIT_M

    z = np.array([[0.0, ALTITUDE_LIMIT_M, 0.0], [0.0, -1.01 * ALTITUDE_LIMIT_M, 0.0], [0.0, np.nan, 0.0]])
    assert altitude_lost_batch(z).tolist() == [False, True, True]  # the limit itself is allowed; NaN is lost
    assert altitude_lost_batch(z + 5.0, z_ref=5.0).tolist() == [False, True, True]
    assert failure_reason(True, True, False) == "diverged"
    assert failure_reason(False, True, True) == "altitude lost"
    assert failure_reason(False, False, False) == "not settled"
    assert failure_reason(False, None, True) is None
    # compute_metrics: a run that settles horizontally but falls 10 m is a failure, not a success: the vehicle
    # is lost (diverged), the verdict names the cause, and a lost run has no settling time
    t = np.linspace(0.0, 10.0, 1001)
    m = compute_metrics(t, along(2.5 * np.exp(-t)), z=0.5 * t**2 / 5.0)
    level = compute_metrics(t, along(2.5 * np.exp(-t)))
    assert level.settling_s is not None and not level.diverged and level.failure is None  # without the fall
    assert m.settling_s is None and m.diverged and m.blew_up is False
    assert m.altitude_lost is True and m.failure == "altitude lost"
    assert level.altitude_lost is None
    assert Metrics.from_json(m.to_json()) == m


# ------------------------------------------------------------------ edges found by mutation testing
# (tests/mutation: each survivor of `make mutation MODULE=metrics` that was not equivalent got a case here;
# the expected values are hand derivations from the definitions in the module docstring)

R = np.array([1.0, 0.0])  # a start direction whose components are exact in every float width


def test_time_vector_rules_one_sample_repeated_instants_and_clear_messages():
    # one sample is a valid (zero-length) run: the fraction of samples at the limit, inside the band
    assert time_on_limit_fraction([0.0], [30.0], 30.0) == 1.0
    assert settling_time([0.0], [[0.01, 0.0]], reference_norm=1.0) == 0.0
    # repeated instants are non-decreasing, so allowed (an integrator's output can repeat a time)
    assert time_on_limit_fraction([0.0, 1.0, 1.0, 2.0], [30.0] * 4, 30.0) == 1.0
    with pytest.raises(ValueError, match="1-D and non-empty"):
        time_on_limit_fraction(np.zeros((2, 2)), np.zeros((2, 2)), 1.0)
    with pytest.raises(ValueError, match="1-D and non-empty"):
        time_on_limit_fraction([], [], 1.0)
    with pytest.raises(ValueError, match="^time vector must be non-decreasing$"):
        time_on_limit_fraction([1.0, 0.0], [0.0, 0.0], 1.0)  # two samples, backwards


def test_position_shape_messages_name_the_expected_shape():
    t = np.linspace(0.0, 1.0, 5)
    with pytest.raises(ValueError, match=r"must have shape \(N, 2\), got \(5, 3\)"):
        settling_time(t, np.zeros((5, 3)))
    with pytest.raises(ValueError, match=r"must have shape \(B, N, 2\), got \(5, 2\)"):
        settling_time_batch(t, np.ones((5, 2)))
    with pytest.raises(ValueError, match="positions have 4 samples but the time vector has 5"):
        settling_time(t, np.ones((4, 2)))
    with pytest.raises(ValueError, match="signal has shape"):
        time_on_limit_fraction(t, np.ones(4), 1.0)
    with pytest.raises(ValueError, match="signal has shape"):
        rms_after(t, np.ones(4), 0.0)


def test_settling_edge_cases_by_hand():
    t = np.arange(3.0)
    # a sample exactly on the band edge is inside (outside means beyond the band): 0.5 m band, 1 m start
    assert settling_time(t, np.outer([1.0, 0.75, 0.5], R), band_fraction=0.5) == 2.0
    # last sample inside, the one before outside: crossing at 1 + (0.1 - 0.05)/(0.1 - 0.01) s
    assert settling_time(t, from_distances([2.5, 0.1, 0.01])) == pytest.approx(1.0 + 0.05 / 0.09, abs=1e-12)
    # last sample outside, the one before inside: not settled
    assert settling_time(t, from_distances([2.5, 0.01, 0.1])) is None
    # in a batch, a run that never leaves its band settles at 0 whatever the others do
    runs = np.stack([from_distances([2.5, 0.1, 0.01]), from_distances([0.01, 0.02, 0.0])])
    out = settling_time_batch(t, runs, reference_norm=[2.5, 2.5])
    assert out[0] == pytest.approx(1.0 + 0.05 / 0.09, abs=1e-12) and out[1] == 0.0


def test_metrics_are_silent_on_the_runs_they_mark_nan():
    """A run ending outside, an infinite sample, a run from the origin: nan or None, and no RuntimeWarning."""
    import warnings

    t = np.arange(4.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert settling_time(t, from_distances([2.5, 0.01, 0.01, 0.1])) is None  # ends outside
        assert settling_time(t, from_distances([2.5, np.inf, 0.01, 0.0])) == 2.0  # inf outside, then inside
        assert math.isnan(overshoot_pct_batch(t, np.zeros((1, 4, 2)))[0])  # starts at the origin


def test_overshoot_of_a_short_start_and_of_an_infinite_sample():
    t = np.arange(3.0)
    # 0.3 m start, 0.03 m past the origin: 10 % (a start below 1 m is as valid as any)
    assert overshoot_pct(t, np.outer([0.3, -0.03, 0.0], R)) == pytest.approx(10.0, abs=1e-12)
    assert overshoot_pct_batch(t, np.outer([0.3, -0.03, 0.0], R)[None])[0] == pytest.approx(10.0, abs=1e-12)
    # an infinite sample far along the start direction: a non-finite run has no overshoot (nan)
    assert math.isnan(overshoot_pct(t, np.array([[2.5, 0.0], [np.inf, 0.0], [-0.25, 0.0]])))
    with pytest.raises(SimulationError, match="^overshoot is undefined for a run starting at the origin$"):
        overshoot_pct(t, np.zeros((3, 2)))


def test_time_on_limit_fraction_by_hand():
    # the threshold itself counts (|value| >= limit (1 - rel_tol)), here with rel_tol 0
    assert time_on_limit_fraction([0.0, 1.0], [30.0, 30.0], 30.0, rel_tol=0.0) == 1.0
    # a run starting at t = 5 s: indicator [1, 1, 0] on [5, 6, 7] -> (1 + 0.5) / 2
    assert time_on_limit_fraction([5.0, 6.0, 7.0], [30.0, 30.0, 0.0], 30.0) == pytest.approx(0.75, abs=1e-15)
    # a run shorter than 1 s, uneven steps: (0.1 * 1 + 0.4 * 0.5) / 0.5, not the sample mean 2/3
    assert time_on_limit_fraction([0.0, 0.1, 0.5], [30.0, 30.0, 0.0], 30.0) == pytest.approx(0.6, abs=1e-15)
    # all samples at one instant: the fraction of samples
    assert time_on_limit_fraction([1.0, 1.0, 1.0], [30.0, 0.0, -30.0], 30.0) == pytest.approx(2.0 / 3.0, abs=1e-15)


def test_rms_after_by_hand():
    # the default keeps the mean: a constant 2 has RMS 2
    assert rms_after([0.0, 1.0, 2.0], [2.0, 2.0, 2.0], 0.0) == pytest.approx(2.0, abs=1e-15)
    # a window of one instant holding two samples [3, -1]: RMS sqrt((9 + 1)/2), about the mean 1: 2
    assert rms_after([0.0, 1.0, 1.0], [9.0, 3.0, -1.0], 1.0) == pytest.approx(math.sqrt(5.0), abs=1e-15)
    assert rms_after([0.0, 1.0, 1.0], [9.0, 3.0, -1.0], 1.0, remove_mean=True) == pytest.approx(2.0, abs=1e-15)
    # a single sample in the window: its magnitude
    assert rms_after([0.0, 1.0], [5.0, -4.0], 1.0) == 4.0
    # a window shorter than 1 s, uneven steps: trapezoid of s^2 = 0.1 * 1 + 0.4 * 5 = 2.1 over 0.5 s
    assert rms_after([0.0, 0.1, 0.5], [1.0, 1.0, 3.0], 0.0) == pytest.approx(math.sqrt(4.2), abs=1e-14)


def test_float32_inputs_give_the_float64_answer():
    """Logged data often comes as float32; the metrics must still compute in float64.

    Every value below is exact in float32, so the hand answer holds to float64 rounding; a computation
    in float32 would be off by ~1e-8 relative.
    """
    f32 = np.float32
    t = np.arange(4.0)
    d = np.array([1.0, 0.5, 0.03125, 0.0078125])  # 1, 1/2, 2^-5, 2^-7: exact in float32
    # 2 % band of 1 m: crossing between t = 2 and 3 at 2 + (2^-5 - 0.02) / (2^-5 - 2^-7) = 2.48 s
    assert settling_time(t, np.outer(d, R).astype(f32)) == pytest.approx(2.48, abs=1e-12)
    assert settling_time(t, np.outer(d, R), reference_norm=f32(1.0)) == pytest.approx(2.48, abs=1e-12)
    # start (3, 4) m, sample (-0.375, -0.5) m: 0.625 m past the origin along e0 = (0.6, 0.8): 12.5 %
    xy = np.array([[3.0, 4.0], [-0.375, -0.5], [0.0, 0.0]], dtype=f32)
    assert overshoot_pct(t[:3], xy) == pytest.approx(12.5, abs=1e-12)
    # a pure roll or pitch of 0.3 rad (as a float32) is that angle
    a = f32(0.3)
    assert tilt_deg(a, 0.0) == pytest.approx(math.degrees(float(a)), rel=1e-14)
    assert tilt_deg(0.0, a) == pytest.approx(math.degrees(float(a)), rel=1e-14)
    # RMS of a constant c is |c|: the float32 square of c = 0.1f is rounded, the float64 one is not
    c = float(f32(0.1))
    assert rms_after(t, np.full(4, c, dtype=f32), 0.0) == pytest.approx(c, rel=1e-14)
    # float32 sample times: linear interpolation between t = 0.1f and 0.7f at (0.5 - 0.02) / (0.5 - 2^-7)
    t1, t2 = float(f32(0.1)), float(f32(0.7))
    got = settling_time(np.array([0.0, t1, t2], dtype=f32), np.outer([1.0, 0.5, 0.0078125], R))
    assert got == pytest.approx(t1 + 0.48 / 0.4921875 * (t2 - t1), rel=1e-14)
    # a float32 limit of 3 with rel_tol 0.1: the threshold is 3 x 0.9 = 2.7 (float32 would round it to 2.6999998)
    assert time_on_limit_fraction([0.0, 1.0], [2.6999999, 2.6999999], f32(3.0), rel_tol=0.1) == 0.0


def test_raw_int16_counts_at_their_most_negative_value():
    """Raw logger counts are often int16; -32768 has magnitude 32768, which int16 cannot hold (abs overflows)."""
    counts = np.array([-32768, 100], dtype=np.int16)
    assert peak_abs(counts) == 32768.0
    assert time_on_limit_fraction([0.0, 1.0], np.array([-32768, -32768], dtype=np.int16), 32768.0) == 1.0

def test_diverged_means_lost_and_the_verdict_names_the_cause():
    """Hand-built runs with known answers: blown up (nan, far), fallen, fine -- flags, verdict and settling."""
    from nniquad.sim.verdicts import altitude_lost_batch, blew_up_batch
    from nniquad.config import ALTITUDE_LIMIT_M, DIVERGENCE_FACTOR

    t = np.linspace(0.0, 10.0, 1001)
    decay = along(2.5 * np.exp(-t))
    level = np.zeros_like(t)
    fall = level.copy()
    fall[500:] = 1.01 * ALTITUDE_LIMIT_M  # beyond the limit for the second half only
    nan_xy = decay.copy()
    nan_xy[700] = np.nan
    far = decay.copy()
    far[300] = [1.01 * DIVERGENCE_FACTOR * 2.5, 0.0]
    cases = {  # name: (xy, z, diverged, blew_up, altitude_lost, failure)
        "fine": (decay, level, False, False, False, None),
        "fallen": (decay, fall, True, False, True, "altitude lost"),
        "nan": (nan_xy, level, True, True, False, "diverged"),
        "far and fallen": (far, fall, True, True, True, "diverged"),
        "nan altitude": (decay, np.where(t > 5, np.nan, 0.0), True, True, True, "diverged"),
    }
    xy_b = np.stack([c[0] for c in cases.values()])
    z_b = np.stack([c[1] for c in cases.values()])
    assert diverged_batch(xy_b, z_batch=z_b).tolist() == [c[2] for c in cases.values()]
    assert blew_up_batch(xy_b, z_batch=z_b).tolist() == [c[3] for c in cases.values()]
    assert altitude_lost_batch(z_b).tolist() == [c[4] for c in cases.values()]
    for name, (xy, z, div, blew, lost, failure) in cases.items():
        m = compute_metrics(t, xy, z=z)
        assert (m.diverged, m.blew_up, m.altitude_lost, m.failure) == (div, blew, lost, failure), name
        assert (m.settling_s is None) == div, name  # a lost vehicle never counts as settled
        assert diverged(xy, z=z) is div, name
    # without an altitude signal (linear, reduced models) only a blow-up can lose the run
    assert diverged(decay) is False and diverged(far) is True
    # the caller's altitude limit (a Monte Carlo --altitude-limit) is the one applied
    assert diverged(decay, z=fall, altitude_limit_m=1.1 * ALTITUDE_LIMIT_M) is False

