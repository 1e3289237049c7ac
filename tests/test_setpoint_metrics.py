"""Success measured to the setpoint, the steady offset and the noise budget (issue 44).

References are independent of the code under test: the static force balance of
each law derived by hand (NNI: ``z = ξ/δ`` at rest, so ``m̂ (k_p - 1/(m̂ δ)) ξ = F``;
sni2: the filter's DC gain ``k/ω²``, so ``m̂ k_p (1 - γ) ξ = F`` with
``γ = k/(m̂ k_p ω²)``), hand counts on synthetic arrays and the closed-form RMS of
a sine over whole periods.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import nniquad.study as mc
from nniquad.laws.nni import Gains
from nniquad.laws.sni2 import SNI2Gains
from nniquad.model.vehicle import PAPER_VEHICLE
from nniquad.sim import SimOptions, simulate
from nniquad.sim.metrics import rotor_limit_share, steady_offset_m
from nniquad.sim.verdicts import compute_metrics

M = PAPER_VEHICLE.m
# tuned gains (test_montecarlo): gamma = 1/(m kp delta) = 0.80
NNI = Gains(13.148341568334407, 25.27258951977003, 0.19046572101699574)
SNI2 = SNI2Gains(kp=20.0, k=0.5 * M * 20.0 * 6.0**2, omega=6.0, zeta=0.8)  # gamma = 0.5


def _hand_offset(force: float, kp: float, gamma: float) -> float:
    """``F / (m̂ k_p (1 - γ))``: the static balance of a law without integral action."""
    return force / (M * kp * (1.0 - gamma))


@pytest.mark.parametrize("gains, gamma", [(NNI, 1.0 / (M * NNI.kp * NNI.delta)),
                                          (SNI2, SNI2.k / (M * SNI2.kp * SNI2.omega**2))], ids=["nni", "sni2"])
def test_steady_offset_equals_the_hand_formula_under_a_constant_force(gains, gamma):
    force = 0.1 * M * PAPER_VEHICLE.g  # 10 % of the weight, along a diagonal
    fx, fy = force / math.sqrt(2), force / math.sqrt(2)
    res = simulate(PAPER_VEHICLE, gains, SimOptions(model="reduced", horizon_s=40.0, wind_N=(fx, fy), xi0=(1.0, 0.0)))
    m = res[0].metrics()
    assert m.steady_offset_m == pytest.approx(_hand_offset(force, gains.kp, gamma), rel=1e-4)
    # outside the 2 % band around the setpoint: the verdict measured to the setpoint is "not settled"
    assert m.steady_offset_m > 0.02 and m.failure == "not settled"


def test_montecarlo_fails_a_run_that_settles_to_a_displaced_equilibrium():
    """The run converges (to the wind's equilibrium, settling about it is finite) but not to the setpoint."""
    setup = mc.study_setup_from(PAPER_VEHICLE, NNI, horizon_s=12.0)
    fixed = mc.ScenarioRanges(mass_factor=(1.0, 1.0), inertia_factor=(1.0, 1.0), attitude_gain_factor=(1.0, 1.0),
                              tau_motor_factor=(1.0, 1.0), noise_sigma_m=(0.0, 0.0), wind_N=(0.0, 0.0))
    base = mc.draw_scenario(0, 44, fixed, setup)
    band = base.band_m
    hand = _hand_offset(1.0, NNI.kp, 1.0 / (M * NNI.kp * NNI.delta))  # offset per newton
    far = base.with_params(run={"wind_x": 3.0 * band / hand, "wind_y": 0.0})
    near = base.with_params(run={"wind_x": 0.3 * band / hand, "wind_y": 0.0})
    r_far, r_near = mc.run_scenarios([far, near])
    assert not r_far.success and r_far.failure == "not settled" and r_far.settling_s is None
    assert r_far.settling_time_about_wind_equilibrium_s is not None
    assert 0 < r_far.settling_time_about_wind_equilibrium_s < setup.horizon_s
    assert r_far.steady_offset_m == pytest.approx(3.0 * band, rel=2e-3)
    assert r_far.offset_m == pytest.approx(3.0 * band, rel=1e-9)
    # the same run with a wind whose equilibrium lies inside the band succeeds
    assert r_near.success and r_near.settling_s is not None
    assert r_near.steady_offset_m == pytest.approx(0.3 * band, rel=2e-3)
    summary = mc.summarize([r_far, r_near]).to_json()
    assert summary["n_success"] == 1 and summary["failures"] == {"not settled": 1}
    assert summary["steady_offset_m"]["max"] == pytest.approx(r_far.steady_offset_m)
    assert "settling_time_about_wind_equilibrium_s" in summary


def test_rotor_limit_share_is_the_hand_count():
    w_max = 800.0
    w = np.array([[400.0, 400.0, 400.0, 400.0],   # free
                  [800.0, 400.0, 400.0, 400.0],   # at the top
                  [400.0, 0.0, 400.0, 400.0],     # at the bottom
                  [400.0, 400.0, 799.9, 400.0],   # close but free (0.0125 % below)
                  [0.0, 800.0, 0.0, 800.0],       # several at once: one step
                  [400.0, 400.0, 400.0, 800.0 * (1 - 1e-9)]])  # at the top up to rounding
    assert rotor_limit_share(w, w_max) == pytest.approx(4 / 6, abs=0)
    with pytest.raises(ValueError):
        rotor_limit_share(w[0], w_max)


def test_tilt_command_rms_over_the_hover_window_is_the_hand_value():
    t = np.linspace(0.0, 10.0, 10001)
    amp, bias = 3.0, 1.5
    cmd = bias + amp * np.sin(2 * np.pi * t)  # whole periods: RMS^2 = bias^2 + amp^2/2
    # a hover run (starts at the setpoint): the window is the whole run
    hover = compute_metrics(t, np.zeros((t.size, 2)), cmd_tilt_deg=cmd)
    assert hover.tilt_command_rms_deg == pytest.approx(math.sqrt(bias**2 + amp**2 / 2), rel=1e-6)
    # judged in the band of the nominal start, 2 % of 2.5 m = 5 cm: a 4 cm excursion is inside, 6 cm is not
    assert hover.settling_s == 0.0 and hover.overshoot_pct is None
    bump = np.column_stack([np.where((t > 3) & (t < 4), 1.0, 0.0), np.zeros_like(t)])
    assert compute_metrics(t, 0.04 * bump).settling_s == 0.0
    assert compute_metrics(t, 0.06 * bump).settling_s == pytest.approx(4.0, abs=1e-3)
    # a run from 1 m that reaches the setpoint at t = 2 s: the window starts at its settling time, 1.96 s
    # (2 % band), and the large command before it does not count
    xy = np.column_stack([np.clip(1.0 - t / 2.0, 0.0, None), np.zeros_like(t)])
    late = np.where(t >= 1.96 - 1e-9, cmd, 25.0)
    m = compute_metrics(t, xy, cmd_tilt_deg=late)
    assert m.settling_s == pytest.approx(1.96)
    window = t >= 1.96 - 1e-9
    hand = math.sqrt(np.trapezoid(cmd[window] ** 2, t[window]) / (t[-1] - 1.96))
    assert m.tilt_command_rms_deg == pytest.approx(hand, rel=1e-9)
    assert m.steady_offset_m == 0.0  # at the setpoint for the last second
    # steady offset: the time average over the last second of a distance that ramps 0.1 -> 0.2 m
    ramp = np.column_stack([np.zeros_like(t), 0.1 + 0.1 * np.clip(t - 9.0, 0.0, None)])
    assert steady_offset_m(t, ramp) == pytest.approx(0.15, rel=1e-12)


def test_rotor_commands_are_the_rotor_speeds_without_motor_lag():
    """Without the motor lag the rotors turn at the commanded speed: the new outputs equal the old ones."""
    res = simulate(PAPER_VEHICLE, NNI, SimOptions(model="full", horizon_s=1.0, motor_lag=False))
    tr = res[0]
    np.testing.assert_array_equal(tr.rotor_commands, tr.rotor_speeds)
    assert tr.metrics().rotor_limit_share == rotor_limit_share(tr.rotor_speeds, PAPER_VEHICLE.omega_max)


# ----------------------------------------------------------------------------- certificates


def _committed(name: str) -> dict:
    import json
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "designs" / f"{name}_certificate.json"
    return json.loads(path.read_text())


def _resigned(doc: dict) -> dict:
    from nniquad.certificates import canonical_digest

    doc["digest"]["value"] = canonical_digest(doc)
    return doc


def _checks_until_failure(doc: dict) -> dict[str, bool]:
    from nniquad.certificates import verify_certificate

    return {c.name: c.ok for c in verify_certificate(doc, fail_fast=True).checks}


def test_an_older_certificate_states_no_steady_offset_and_is_compared_without_it():
    """A certificate written before issue 44 (no ``steady_offset_m``, no ``offset_abs_m``) keeps its meaning."""
    from nniquad.certificates import TOLERANCES
    from nniquad.certificates.certificate import Certificate

    doc = _committed("sni2_paper")
    assert "offset_abs_m" not in doc["tolerances"] and "steady_offset_m" not in doc["performance"]["full"]
    run = Certificate.from_json(doc).run_settings("reduced")
    assert "steady_offset_m" not in run.stated
    got = {**dict(run.stated), "steady_offset_m": 0.5}  # whatever the offset: it is not claimed
    assert run.differences(got, TOLERANCES) == []
    # stated by a newer certificate, it is compared within its tolerance
    doc["performance"]["reduced"]["steady_offset_m"] = 0.0
    stated = Certificate.from_json(_resigned(doc))
    assert stated.run_settings("reduced").differences(got, TOLERANCES) == ["steady_offset_m"]


def test_a_steady_offset_stated_without_its_tolerance_is_refused():
    """Re-signed: an older certificate that gains a stated offset but keeps the older tolerances fails ``verify``'s
    tolerance check; with the tolerance, the tolerance and layout checks pass (a later check is broken on purpose,
    so that ``fail_fast`` stops there instead of recomputing the whole certificate)."""
    from nniquad.certificates import TOLERANCES

    doc = _committed("sni2_paper")
    doc["performance"]["full"]["settings"]["horizon_s"] += 1.0  # the settings check fails
    older = _checks_until_failure(_resigned(doc))
    assert older["tolerances"] and older["layout"] and older["settings"] is False  # as committed: older, consistent
    for model in ("reduced", "full"):
        doc["performance"][model]["steady_offset_m"] = 0.0
    without = _checks_until_failure(_resigned(doc))
    assert without["tolerances"] is False and "layout" not in without
    doc["tolerances"] = dict(TOLERANCES)
    checks = _checks_until_failure(_resigned(doc))
    assert checks["tolerances"] and checks["layout"] and checks["settings"] is False
