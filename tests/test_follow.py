"""Following a reference: the error against a hand-computed linear-loop response, the feedforward under the tilt
limit, a start from motion without a jump in the command, and the tracking metrics on constructed runs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nniquad.control.references import Circle, FigureEight, MinimumJerk, TimeShifted
from nniquad.errors import SimulationError
from nniquad.laws.nni import PAPER_GAINS
from nniquad.laws.pd_filtered import PDFilteredGains
from nniquad.laws.pd_velocity import PDGains
from nniquad.laws.sni2 import SNI2Gains
from nniquad.model.vehicle import PAPER_VEHICLE
from nniquad.sim import SimOptions, simulate
from nniquad.sim.tracking import arrivals, tracking_metrics

EIGHT = FigureEight(2.0, 1.0, 8.0)
LAWS = {"nni": PAPER_GAINS, "sni2": SNI2Gains(kp=12.0, k=760.0, omega=12.0, zeta=1.7),
        "pd_velocity": PDGains(kp=4.0, kd=3.0), "pd_filtered": PDFilteredGains(kp=9.0, kd=4.4, tau_f=0.05)}


def _steady_error(feedforward: bool, r: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The periodic error ``e``, ``ė`` and the NNI state ``z`` of the linear loop on :data:`EIGHT`, by hand.

    Per axis, with ``ξ_d = A sin Ωt`` and ``r = m̂/m``: ``ë + r k_p e - r z/m̂ = r a_ff - ξ̈_d``,
    ``z = Γ/(s + Γδ) e``; the forcing's phasor is ``(r - 1)(-A Ω²)`` with feedforward, ``A Ω²`` without, and
    ``E = D / (-Ω² + r k_p - r C(jΩ)/m̂)``.
    """
    g, m_hat = PAPER_GAINS, PAPER_VEHICLE.m
    w = 2 * math.pi / EIGHT.period_s
    e, de, z = (np.zeros((t.size, 2)) for _ in range(3))
    for axis, (A, W) in enumerate(((EIGHT.ax_m, w), (EIGHT.ay_m, 2 * w))):
        D = (r - 1) * (-A * W**2) if feedforward else A * W**2
        C = g.Gamma / (1j * W + g.Gamma * g.delta)
        E = D / (-W**2 + r * g.kp - r * C / m_hat)
        phase = np.exp(1j * W * t)
        e[:, axis], de[:, axis], z[:, axis] = (np.imag(X * phase) for X in (E, 1j * W * E, C * E))
    return e, de, z


@pytest.mark.parametrize("feedforward", [True, False])
def test_error_matches_the_hand_computed_linear_loop_response(feedforward):
    """Linear model, 25 % heavier than the controller assumes, started on the periodic solution: the simulated
    error is the phasor response computed by hand (with feedforward only the mass error's share is left)."""
    r = 1 / 1.25
    t0 = np.zeros(1)
    e0, de0, z0 = _steady_error(feedforward, r, t0)
    p, v, _ = EIGHT.sample(0.0)
    o = SimOptions(model="linear", horizon_s=8.0, reference=EIGHT, feedforward=feedforward,
                   true_mass_kg=PAPER_VEHICLE.m / r, xi0=tuple(p[0] + e0[0]), v0=tuple(v[0] + de0[0]),
                   zc0=tuple(z0[0]))
    tr = simulate(PAPER_VEHICLE, PAPER_GAINS, o)[0]
    want, _, _ = _steady_error(feedforward, r, tr.t)
    got = tr.xy - EIGHT.position(tr.t)
    assert np.max(np.abs(got - want)) < 1e-3 * np.max(np.abs(want))
    m = tr.tracking()
    assert m.tracking_max_m == pytest.approx(np.max(np.hypot(*want.T)), rel=1e-3)


@pytest.mark.parametrize("law", sorted(LAWS))
def test_on_the_reference_with_feedforward_the_error_stays_zero(law):
    """Nominal mass, linear model, started on the reference from motion: the command is the feedforward alone and
    the error stays zero for every law (a law that measures the velocity is given ``ξ̇ - ξ̇_d``); from rest the
    same run leaves the reference."""
    p, v, _ = EIGHT.sample(0.0)
    o = SimOptions(model="linear", horizon_s=4.0, reference=EIGHT, feedforward=True, xi0=tuple(p[0]),
                   v0=tuple(v[0]))
    moving, still = simulate(PAPER_VEHICLE, [LAWS[law]] * 2, [o, o.with_(v0=(0.0, 0.0))])
    assert moving.tracking().tracking_max_m < 1e-6
    assert still.tracking().tracking_max_m > 0.05


def _max_step(a: np.ndarray) -> float:
    return float(np.max(np.hypot(*np.diff(a, axis=0).T)))


def test_a_take_over_from_a_running_state_continues_the_run():
    """Run B starts at 3 s from run A's position, velocity and NNI state (``zc0``; the law's take-over state is zero)
    on the reference shifted by 3 s: B is A from 3 s on, command included.  Reduced model, 10 % mass error so the
    error is not zero.  Started at rest instead, it is not."""
    o = SimOptions(model="reduced", horizon_s=6.0, reference=EIGHT, feedforward=True,
                   true_mass_kg=1.1 * PAPER_VEHICLE.m, xi0=tuple(EIGHT.sample(0.0)[0][0]),
                   v0=tuple(EIGHT.sample(0.0)[1][0]))
    a = simulate(PAPER_VEHICLE, PAPER_GAINS, o)[0]
    k = int(round(3.0 / o.output_dt_s))
    state = lambda *names: tuple(a.state[k, [a.state_names.index(n) for n in names]])  # noqa: E731
    ob = o.with_(horizon_s=3.0, reference=TimeShifted(EIGHT, 3.0), xi0=tuple(a.xy[k]), v0=state("x_dot", "y_dot"),
                 zc0=state("zc_x", "zc_y"))
    b, rest = simulate(PAPER_VEHICLE, [PAPER_GAINS] * 2, [ob, ob.with_(v0=(0.0, 0.0))])
    assert 1e-3 < a.tracking(window_s=(3.0, 6.0)).tracking_max_m
    np.testing.assert_allclose(b.xy, a.xy[k:], atol=1e-9)
    np.testing.assert_allclose(b.a_cmd[1:], a.a_cmd[k + 1:], atol=1e-8)
    assert np.max(np.abs(rest.xy - a.xy[k:])) > 0.05


def _max_step(a: np.ndarray) -> float:
    return float(np.max(np.hypot(*np.diff(a, axis=0).T)))


def test_a_start_from_motion_on_the_reference_has_no_jump_in_the_command():
    """The discrete sni2 law at 100 Hz (its take-over state is not zero in general, and zero for a zero error),
    reduced model, 10 % mass error: started on the figure-eight with its velocity, the first command is the
    feedforward ``ξ̈_d(0)`` and the command moves from sample to sample no more than later in the run.  Started at
    rest instead, the command steps away."""
    p, v, acc = EIGHT.sample(0.0)
    o = SimOptions(model="reduced", horizon_s=4.0, reference=EIGHT, feedforward=True, controller_sampling="discrete",
                   true_mass_kg=1.1 * PAPER_VEHICLE.m, xi0=tuple(p[0]), v0=tuple(v[0]))
    moving, rest = simulate(PAPER_VEHICLE, [LAWS["sni2"]] * 2, [o, o.with_(v0=(0.0, 0.0))])
    np.testing.assert_allclose(moving.a_cmd[0], acc[0], atol=1e-12)
    later = _max_step(moving.a_cmd[50:])
    assert _max_step(moving.a_cmd[:20]) <= later
    assert _max_step(rest.a_cmd[:20]) > 3 * later


def test_feedforward_joins_before_the_tilt_limit():
    """A circle that demands more than the limit: the commanded tilt still stays at or below it, and the
    demanded tilt reports the excess."""
    fast = Circle(2.0, 2.0)
    p, v, _ = fast.sample(0.0)
    o = SimOptions(model="reduced", horizon_s=2.0, reference=fast, feedforward=True, xi0=tuple(p[0]), v0=tuple(v[0]))
    tr = simulate(PAPER_VEHICLE, PAPER_GAINS, o)[0]
    assert np.max(tr.cmd_tilt_deg) <= o.tilt_limit_deg + 1e-9
    assert np.max(tr.cmd_tilt_deg) == pytest.approx(o.tilt_limit_deg)
    w = 2 * math.pi / 2.0
    assert tr.tracking().demanded_tilt_deg == pytest.approx(math.degrees(math.atan(2.0 * w**2 / PAPER_VEHICLE.g)))


def test_options_refuse_feedforward_without_a_reference_and_keep_old_records():
    with pytest.raises(SimulationError, match="feedforward needs a reference"):
        SimOptions(feedforward=True)
    assert set(SimOptions().to_json()) == set(SimOptions(reference=None).to_json())
    assert "reference" not in SimOptions().to_json() and "v0" not in SimOptions().to_json()
    assert SimOptions(reference=EIGHT).to_json()["reference"]["type"] == "FigureEight"


def test_tracking_rms_and_max_on_a_constructed_run():
    t = np.linspace(0.0, 8.0, 801)
    off = np.c_[0.03 * np.ones_like(t), 0.04 * np.sin(2 * math.pi * t / 8.0)]
    m = tracking_metrics(t, EIGHT.position(t) + off, EIGHT, g=9.81, tilt_limit_deg=30.0)
    # ‖off‖² = 0.03² + 0.04² sin²: its mean over a period is 0.03² + 0.04²/2
    assert m.tracking_rms_m == pytest.approx(math.sqrt(0.03**2 + 0.04**2 / 2), rel=1e-4)
    assert m.tracking_max_m == pytest.approx(0.05, rel=1e-6)
    w = m = tracking_metrics(t, EIGHT.position(t) + off, EIGHT, g=9.81, tilt_limit_deg=30.0, window_s=(2.0, 2.0 + 1e-2))
    assert w.window_s == (2.0, 2.0 + 1e-2) and w.tracking_max_m == pytest.approx(0.05, rel=1e-3)
    with pytest.raises(SimulationError, match="fewer than two samples"):
        tracking_metrics(t, EIGHT.position(t), EIGHT, g=9.81, tilt_limit_deg=30.0, window_s=(20.0, 30.0))


def test_arrivals_on_a_constructed_run():
    """Hold at (2, 0) from 4 s to 5 s, then on to (2, 2): a run that enters the 4 cm band of the first corner at
    4.5 s and stays reaches it at 4.5 s; one that leaves the band again before the hold ends does not."""
    ref = MinimumJerk((0.0, 4.0, 5.0, 9.0), ((0.0, 0.0), (2.0, 0.0), (2.0, 0.0), (2.0, 2.0)))
    t = np.round(np.arange(0.0, 12.0, 0.01), 10)
    xy = ref.position(np.maximum(t - 0.5, 0.0))  # half a second late
    got = arrivals(t, xy, ref)
    assert [a.index for a in got] == [1, 3] and [a.band_m for a in got] == [0.04, 0.04]
    # the late run is within 4 cm of (2, 0) once 2 (1 - s(τ)) <= 0.04, τ = (t - 0.5)/4: solve s(τ) = 0.98
    x = np.arange(0, 1, 1e-6)
    tau = x[np.argmax(x**3 * (10 - 15 * x + 6 * x * x) >= 0.98)]
    assert got[0].arrival_s == pytest.approx(0.5 + 4 * tau, abs=0.011)
    assert got[0].delay_s == pytest.approx(got[0].arrival_s - 4.0)
    xy2 = xy.copy()
    xy2[(t > 4.8) & (t < 4.9)] += [0.1, 0.0]
    assert arrivals(t, xy2, ref)[0].arrival_s == pytest.approx(4.9)
    xy2[t >= 4.95] += [0.1, 0.0]  # never back in the band before the reference leaves
    assert arrivals(t, xy2, ref)[0].arrival_s is None


def test_the_feedforward_is_read_with_the_measurement_and_its_lead():
    """Sampled at 50 Hz: every step carries the reference at the last sample instant and the acceleration
    ``lead`` after it; continuous: at the middle of each step."""
    from nniquad.sim import EXO_FIELDS, exogenous_inputs

    col = {n: EXO_FIELDS.index(n) for n in EXO_FIELDS}
    o = SimOptions(model="reduced", horizon_s=0.5, reference=EIGHT, feedforward=True, feedforward_lead_s=0.07,
                   controller_sampling="held", noise_rate_hz=50.0)
    E = exogenous_inputs(o)
    t = np.arange(E.shape[0]) * o.dt_s
    sample = np.floor(t * 50.0 + 1e-9) / 50.0
    p, v, _ = EIGHT.sample(sample)
    np.testing.assert_array_equal(E[:, [col["ref_x"], col["ref_y"]]], p)
    np.testing.assert_array_equal(E[:, [col["ref_vx"], col["ref_vy"]]], v)
    np.testing.assert_array_equal(E[:, [col["ff_x"], col["ff_y"]]], EIGHT.sample(sample + 0.07)[2])
    E = exogenous_inputs(o.with_(controller_sampling="continuous", feedforward_lead_s=0.0))
    np.testing.assert_allclose(E[:, [col["ff_x"], col["ff_y"]]], EIGHT.sample(t + 0.5 * o.dt_s)[2], rtol=0, atol=1e-15)
    with pytest.raises(SimulationError, match="lead needs the feedforward"):
        o.with_(feedforward=False)


def test_a_setpoint_step_is_the_regulation_run_shifted():
    """Reduced model, discrete sni2 law: a setpoint at (1, 0.5) m from t = 0 (then another at 2 s), flown from the
    origin at rest, is the plain regulation run from (-1, -0.5) m shifted by the setpoint, until the next step."""
    from nniquad.control.references import SetpointSteps

    steps = SetpointSteps((0.0, 2.0), ((1.0, 0.5), (-1.0, 0.0)))
    o = SimOptions(model="reduced", horizon_s=3.0, controller_sampling="discrete")
    followed, plain = simulate(PAPER_VEHICLE, [LAWS["sni2"]] * 2,
                               [o.with_(reference=steps, xi0=(0.0, 0.0)), o.with_(xi0=(-1.0, -0.5))])
    before = followed.t < 2.0
    np.testing.assert_allclose(followed.xy[before] - [1.0, 0.5], plain.xy[before], atol=1e-12)
    assert np.hypot(*(followed.xy[-1] - plain.xy[-1])) > 0.1  # the second step moved it
