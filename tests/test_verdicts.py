"""Run verdicts (divergence, altitude loss, the one failure) and the metrics bundle, by hand.

Each case is derived from the definitions in :mod:`nniquad.sim.verdicts` and
:mod:`nniquad.sim.metrics` (most were written for the survivors of
``make mutation MODULE=verdicts``).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from nniquad.sim.verdicts import Metrics, altitude_lost_batch, compute_metrics, diverged, diverged_batch
from nniquad.config import ALTITUDE_LIMIT_M, DIVERGENCE_FACTOR
from nniquad.errors import SimulationError

R = np.array([1.0, 0.0])


def line(distances) -> np.ndarray:
    """Positions along x at the given distances [m]."""
    return np.outer(np.asarray(distances, dtype=float), R)


# ------------------------------------------------------------------------ divergence


def test_divergence_threshold_is_strict_and_per_run():
    # "beyond" the threshold: exactly on it is not diverged
    assert not diverged(line([1.0, 10.0, 0.0]), threshold_m=10.0)
    assert diverged(line([1.0, 10.000001, 0.0]), threshold_m=10.0)
    # an explicit threshold for a batch of 2 runs of 3 samples
    flags = diverged_batch(np.stack([line([1.0, 5.0, 0.0]), line([1.0, 11.0, 0.0])]), threshold_m=10.0)
    assert flags.tolist() == [False, True]


def test_divergence_scale_rules():
    assert DIVERGENCE_FACTOR == 100.0  # the distances below are 100 x the scale
    # a 0.5 m start: threshold 50 m, so 60 m is beyond it
    assert diverged(line([0.5, 60.0, 0.0]))
    assert not diverged(line([0.5, 40.0, 0.0]))
    # a run from the origin has no scale: 1 m, so 50 m is within 100 m
    assert not diverged(line([0.0, 50.0, 0.0]))
    assert not diverged(line([2.5, 50.0, 0.0]), scale_m=0.0)
    # an infinite scale is no scale either: 1 m, so 150 m is beyond
    assert diverged(line([2.5, 150.0, 0.0]), scale_m=math.inf)
    # another factor: 10 x 2.5 m
    assert diverged(line([2.5, 30.0, 0.0]), factor=10.0) and not diverged(line([2.5, 30.0, 0.0]))
    # a single-sample run with an explicit scale
    assert not diverged(line([2.5]), scale_m=1.0)


def test_non_finite_position_or_altitude_per_run():
    finite_z = np.zeros(3)
    assert diverged(np.array([[2.5, 0.0], [np.nan, 0.0], [0.0, 0.0]]), z=finite_z)  # finite z keeps a NaN position
    z = np.array([[0.0, 0.0, 0.0], [0.0, np.inf, 0.0]])
    assert diverged_batch(np.stack([line([2.5, 1.0, 0.0])] * 2), z_batch=z).tolist() == [False, True]


def test_position_shape_errors():
    with pytest.raises(ValueError, match=r"^positions must have shape \(N, 2\), got \(2,\)$"):
        diverged(np.zeros(2))
    with pytest.raises(ValueError, match=r"^positions must have shape \(B, N, 2\), got \(5, 2\)$"):
        diverged_batch(np.zeros((5, 2)))
    with pytest.raises(ValueError, match=r"^altitudes must have shape \(B, N\), got \(3,\)$"):
        altitude_lost_batch(np.zeros(3))


def test_float32_positions_and_scale_at_float64_precision():
    # hypot(100, 0.001f) = 100.000000005 m > 100 m (float32 would round it to 100 exactly)
    xy = np.array([[1.0, 0.0], [100.0, 0.001]], dtype=np.float32)
    assert diverged_batch(xy[None])[0]
    # scale 0.1f = 0.10000000149 m: threshold 10.000000149 m, so 10.0000001 m is within (float32: 10 m)
    assert not diverged(line([2.5, 10.0000001, 0.0]), scale_m=np.float32(0.1))


# --------------------------------------------------------------------- altitude loss


def test_a_lost_altitude_is_measured_from_its_reference():
    xy = line([2.5, 1.0, 0.0])
    assert not diverged(xy, z=np.full(3, 5.5), z_ref=5.0)  # 0.5 m from the reference
    assert diverged(xy, z=np.full(3, 5.5))  # 5.5 m from the default reference 0
    assert diverged(xy, z=np.full(3, 5.5), z_ref=5.0, altitude_limit_m=0.4)
    assert diverged_batch(xy[None], z_batch=np.full((1, 3), 5.5), z_ref=5.0).tolist() == [False]


def test_altitude_loss_reference_and_limit():
    # the limit itself below the default reference 0 is allowed
    assert altitude_lost_batch(np.array([[0.0, -ALTITUDE_LIMIT_M, 0.0]])).tolist() == [False]
    # float32 altitudes: |2.5 - 0.4999999| = 2.0000001 m > 2 m (float32 would round it to 2)
    assert altitude_lost_batch(np.array([[2.5]], dtype=np.float32), 2.0, 0.4999999).tolist() == [True]


# --------------------------------------------------------------------- the bundle


def test_compute_metrics_reference_altitude_limit_and_horizon():
    t = np.linspace(1.0, 11.0, 1001)  # starts at 1 s: the horizon is 10 s
    xy = line(2.5 * np.exp(-(t - 1.0)))
    m = compute_metrics(t, xy, z=np.full_like(t, 5.5), z_ref=5.0)
    assert m.horizon_s == pytest.approx(10.0, abs=1e-12)
    assert m.altitude_dev_m == pytest.approx(0.5, abs=1e-12) and m.altitude_lost is False
    assert m.diverged is False and m.failure is None  # 0.5 m from its 5 m reference: not lost
    assert compute_metrics(t, xy, z=np.full_like(t, 0.25)).altitude_dev_m == pytest.approx(0.25, abs=1e-12)
    low = compute_metrics(t, xy, z=np.full_like(t, 5.5), z_ref=5.0, altitude_limit_m=0.4)
    assert low.altitude_lost is True and low.diverged is True and low.failure == "altitude lost"
    # float32 altitude: |5 - 0.1| = 4.9 m, not the float32 4.900000095
    m32 = compute_metrics(t, xy, z=np.full(t.size, 5.0, dtype=np.float32), z_ref=0.1)
    assert m32.altitude_dev_m == pytest.approx(4.9, abs=1e-12)


def test_compute_metrics_band_fraction_reaches_settling():
    h = 1e-3
    t = np.arange(0.0, 8.0 + h / 2, h)
    m = compute_metrics(t, line(2.5 * np.exp(-t)), band_fraction=0.05)
    assert m.settling_s == pytest.approx(math.log(20.0), abs=1e-6)


def test_a_diverged_run_has_no_settling_or_overshoot_and_fails_as_diverged():
    t = np.arange(5.0)
    # out to 300 m (beyond 100 x 2.5 m), then back past the origin and to rest: diverged all the same
    m = compute_metrics(t, line([2.5, 300.0, -0.5, 0.0, 0.0]))
    assert m.diverged and m.settling_s is None and m.overshoot_pct is None
    assert m.failure == "diverged"
    # a non-finite altitude with finite positions is a diverged run too
    m_z = compute_metrics(t, line([2.5, 1.0, 0.0, 0.0, 0.0]), z=np.array([0.0, np.nan, 0.0, 0.0, 0.0]))
    assert m_z.diverged and m_z.failure == "diverged"


def test_failure_of_a_good_run_and_of_an_unsettled_one():
    t = np.linspace(0.0, 10.0, 1001)
    good = compute_metrics(t, line(2.5 * np.exp(-t)), z=np.zeros_like(t))
    assert good.failure is None and good.settling_s is not None
    slow = compute_metrics(t, line(2.5 * np.exp(-0.1 * t)))
    assert slow.failure == "not settled"


def test_tilt_fields_need_both_angles_and_use_the_body_tilt_without_a_command():
    t = np.linspace(0.0, 2.0, 2001)
    xy = line(2.5 * np.exp(-t))
    phi = np.radians(np.where(t <= 1.0, 30.0, 10.0))  # at 30 deg (the limit) for the first half
    only_phi = compute_metrics(t, xy, phi=phi)
    assert only_phi.peak_tilt_deg is None and only_phi.tilt_limit_fraction is None
    both = compute_metrics(t, xy, phi=phi, theta=np.zeros_like(t), tilt_limit_deg=30.0)
    assert both.peak_tilt_deg == pytest.approx(30.0, abs=1e-9)
    assert both.tilt_limit_fraction == pytest.approx(0.5, abs=1e-3)  # half the run, give or take a step
    with pytest.raises(ValueError, match=r"^roll/pitch have shape \(3,\) but the time vector has \(2001,\)$"):
        compute_metrics(t, xy, phi=np.zeros(3), theta=np.zeros(3))


def test_a_non_finite_peak_is_reported_as_null():
    t = np.linspace(0.0, 1.0, 11)
    rotors = np.full((11, 4), 600.0)
    rotors[5, 2] = np.nan
    assert compute_metrics(t, line(2.5 * np.exp(-t)), rotor_speeds=rotors).peak_rotor_speed_rad_s is None


# ------------------------------------------------------------------------ JSON


def _metrics(**kw) -> Metrics:
    base = dict(settling_s=1.0, overshoot_pct=0.0, peak_tilt_deg=None, peak_cmd_tilt_deg=None,
                tilt_limit_fraction=None, peak_rotor_speed_rad_s=None, altitude_dev_m=None,
                tilt_jitter_rms_deg=None, diverged=False, horizon_s=10.0)
    base.update(kw)
    return Metrics(**base)


def test_to_json_turns_numpy_scalars_into_json_values_and_non_finite_into_null():
    data = _metrics(diverged=np.bool_(True), settling_s=np.float32(1.5), overshoot_pct=math.nan).to_json()
    assert data["diverged"] is True
    assert data["settling_s"] == 1.5 and type(data["settling_s"]) is float
    assert data["overshoot_pct"] is None
    json.dumps(data, allow_nan=False)  # numpy scalars would not serialise


def test_a_record_without_its_cause_reads_diverged_as_blown_up():
    """Metrics written before `blew_up` existed have it None: then `diverged` stands for the cause."""
    assert _metrics(diverged=True, settling_s=None).failure == "diverged"
    assert _metrics(diverged=True, blew_up=False, altitude_lost=True, settling_s=None).failure == "altitude lost"


def test_from_json_names_the_first_unknown_field():
    data = _metrics().to_json()
    with pytest.raises(SimulationError, match=r"^unknown metrics field 'alpha'$"):
        Metrics.from_json({**data, "zeta": 1, "alpha": 2})
