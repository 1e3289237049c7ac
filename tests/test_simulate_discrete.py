"""The discrete-time controllers in the simulator (``controller_sampling="discrete"``).

Independent references: :class:`nniquad.control.discrete.DiscreteNNI` stepped in
numpy on the simulator's own sampled positions (the controller), and the exact
discrete closed loop :func:`nniquad.analysis.sampled.sampled_reduced_loop`
(``scipy.linalg.expm`` of the plant with its input held) for the whole loop.
"""

from __future__ import annotations

import numpy as np
import pytest

from nniquad.analysis.sampled import sampled_reduced_loop
from nniquad.control.discrete import DiscreteNNI
from nniquad.laws.nni import Gains
from nniquad.laws.pd_filtered import PDFilteredGains
from nniquad.laws.pd_velocity import PDGains
from nniquad.errors import SimulationError
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.sim import SimOptions, SimParams, exogenous_inputs, simulate

G = Gains(kp=3.0, Gamma=2.0, delta=1.0)


def _held(tr) -> np.ndarray:
    return tr.state[:, [tr.state_names.index("held_x"), tr.state_names.index("held_y")]]


@pytest.mark.parametrize("model, rate_hz", [("linear", 100.0), ("reduced", 100.0), ("linear", 50.0), ("full", 100.0)])
def test_controller_equals_discrete_nni_on_the_sampled_positions(model, rate_hz):
    """z_k and a_k of the simulator equal DiscreteNNI stepped on the simulator's held measurements.

    The recorded state at t = (k+1) T holds the period k that just ended: xi_k, z_k and
    the command a_k (the controller advances at the start of the next step).  Noise makes the
    held value differ from the true position, and zc0 != 0 checks that t = 0 does not advance.
    """
    T = 1.0 / rate_hz
    o = SimOptions(model=model, horizon_s=3.0, output_dt_s=T, controller_sampling="discrete", noise_sigma_m=0.01,
                   noise_rate_hz=rate_hz, motor_lag=model == "full", zc0=(0.3, -0.2))
    tr = simulate(V, G, o)[0]
    xi = _held(tr)[1:]
    assert np.all(xi != tr.xy[1:])  # the controller sees the noisy samples
    # the linear model has no tilt limit: the reference's limit set out of reach
    tilt = 89.99 if model == "linear" else o.tilt_limit_deg
    ref = DiscreteNNI.from_gains(G, V.m, V.g, rate_hz, tilt).run(xi, z0=np.array(o.zc0))
    scale = max(1.0, float(np.max(np.abs(ref["z"]))))
    np.testing.assert_allclose(tr.z_c[1:], ref["z"][:-1], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(tr.z_c[0], o.zc0, rtol=0, atol=0)
    if model != "full":  # full: the limit uses the altitude loop's g_z (not recorded), z is checked above
        np.testing.assert_allclose(tr.a_cmd[1:], ref["a_h"], rtol=0, atol=1e-12)
    if model == "reduced":  # the tilt limit is active at the start and released later
        norm = np.hypot(*ref["a_h"].T)
        assert norm.max() > 1.01 * norm.min() and np.isclose(norm[0], V.g * np.tan(np.radians(o.tilt_limit_deg)))
    if model == "full":
        return
    # the command is constant over a period: with output at every step it changes only at samples
    o1 = o.with_(horizon_s=0.5, output_dt_s=o.dt_s)
    a = simulate(V, G, o1)[0].a_cmd
    changes = np.flatnonzero(np.any(np.diff(a, axis=0) != 0, axis=1)) + 1
    steps = int(round(T / o.dt_s))
    assert set(changes) <= set(range(1, len(a), steps)) and len(changes) > 5


def test_linear_loop_equals_the_exact_discrete_closed_loop():
    """The linear model, discrete controller: pos/vel at kT and z_k equal A_d^k x_0 of sampled_reduced_loop."""
    o = SimOptions(model="linear", horizon_s=5.0, output_dt_s=0.01, controller_sampling="discrete", zc0=(0.1, 0.05))
    tr = simulate(V, G, o)[0]
    loop = sampled_reduced_loop(V, G, 100.0, variant="discrete")
    assert loop.state_names[:6] == ("x", "x_dot", "y", "y_dot", "zc_x", "zc_y")
    x = np.array([*o.xi0[:1], 0.0, o.xi0[1], 0.0, *o.zc0])
    xs = [x]
    for _ in range(len(tr.t) - 1):
        x = loop.A_d @ x
        xs.append(x)
    xs = np.array(xs)
    X = tr.state
    np.testing.assert_allclose(X[:, 0:4], xs[:, 0:4], rtol=0, atol=1e-12)
    np.testing.assert_allclose(X[1:, 4:6], xs[:-1, 4:6], rtol=0, atol=1e-12)
    # the held variant is another loop (z follows the held value between samples)
    held = simulate(V, G, o.with_(controller_sampling="held"))[0]
    assert np.max(np.abs(held.xy - tr.xy)) > 1e-3


def test_the_variants_resolve_as_before():
    assert SimOptions().sampling == "continuous" and not SimOptions().sampled
    assert SimOptions(noise_sigma_m=0.01).sampling == "held"
    assert SimOptions(sample_hold=True).sampling == "held"
    d = SimOptions(controller_sampling="discrete")
    assert d.sampled and d.sampling == "discrete" and d.rate_hz == 100.0
    p = SimParams.from_options(V, G, d)
    assert p.run.discrete == 1.0 and p.run.sample_hold == 1.0 and p.run.sample_period == pytest.approx(0.01)
    assert SimParams.from_options(V, G, SimOptions(sample_hold=True)).run.discrete == 0.0
    # the settings round-trip through to_json (the certificate's record of a run)
    assert SimOptions(**{k: v for k, v in d.to_json().items() if k != "inner"}).sampling == "discrete"


def test_sample_flags_mark_the_first_sample():
    o = SimOptions(model="linear", horizon_s=0.1, controller_sampling="discrete", noise_rate_hz=100.0)
    flags = exogenous_inputs(o)[:, 2]
    assert flags[0] == 1.0 and set(flags[10::10]) == {2.0} and np.count_nonzero(flags) == 10


@pytest.mark.parametrize("kwargs, message", [
    ({"controller_sampling": "zoh"}, "unknown controller sampling"),
    ({"controller_sampling": "discrete", "noise_rate_hz": 300.0}, "whole multiple"),
    ({"controller_sampling": "discrete", "sample_hold": False}, "contradicts"),
    ({"controller_sampling": "continuous", "sample_hold": True}, "contradicts"),
])
def test_bad_sampling_options(kwargs, message):
    with pytest.raises(SimulationError, match=message):
        SimOptions(model="linear", **kwargs)


def _exact_pd_loop(kp: float, kd: float, tau_f: float | None, T: float, n: int, xi0: float) -> np.ndarray:
    """One axis of the linear model with a discrete PD law, by hand: the double integrator with its input held
    over T (exact), the filter's exact ZOH step (``tau_f``) or the sampled true velocity (``None``).
    Returns (xi_k, v_k) for k = 0..n."""
    Phi, Gu = np.array([[1.0, T], [0.0, 1.0]]), np.array([T * T / 2.0, T])
    x, d = np.array([xi0, 0.0]), xi0  # at rest; the filter starts at xi(0)
    out = [x]
    for _ in range(n):
        if tau_f is None:
            u = -kp * x[0] - kd * x[1]
        else:
            u = -kp * x[0] - kd * (x[0] - d) / tau_f
            a = np.exp(-T / tau_f)
            d = a * d + (1.0 - a) * x[0]
        x = Phi @ x + Gu * u
        out.append(x)
    return np.array(out)


@pytest.mark.parametrize("gains", [PDGains(kp=3.0, kd=2.0), PDFilteredGains(kp=3.0, kd=2.0, tau_f=0.05)],
                         ids=["pd_velocity", "pd_filtered"])
def test_discrete_pd_laws_equal_the_exact_sampled_loop(gains):
    """The PD laws in discrete time: position and velocity at kT equal the hand-written exact sampled loop
    (double integrator with the command held, the filter's exact ZOH step or the sampled velocity); the
    held variant is another loop."""
    T = 0.02
    o = SimOptions(model="linear", horizon_s=4.0, output_dt_s=T, controller_sampling="discrete", noise_rate_hz=1 / T)
    tr = simulate(V, gains, o)[0]
    for axis, (pos, vel) in enumerate(((0, 1), (2, 3))):
        ref = _exact_pd_loop(gains.kp, gains.kd, getattr(gains, "tau_f", None), T, len(tr.t) - 1, o.xi0[axis])
        np.testing.assert_allclose(tr.state[:, [pos, vel]], ref, rtol=0, atol=1e-10)
    held = simulate(V, gains, o.with_(controller_sampling="held"))[0]
    assert np.max(np.abs(held.xy - tr.xy)) > 1e-3


def test_discrete_variant_period_must_match():
    o = SimOptions(model="linear", horizon_s=0.1, controller_sampling="discrete")
    p = SimParams.from_options(V, G, o).with_(run={"sample_period": 0.02})
    with pytest.raises(SimulationError, match="differs from the sample period"):
        simulate(None, None, o, params=p)
