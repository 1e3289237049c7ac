"""Simulation: checked against independent computations (matrix exponential, scipy's solve_ivp,
the linearisation with the attitude lag, the sympy-generated mixer), plus option validation."""

from __future__ import annotations

import hashlib
import math
import os
import shutil
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from nniquad import codecache, sim
from nniquad.errors import GainError, SimulationError
from nniquad.control.inner_loops import allocate
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.laws.nni import PAPER_GAINS, Gains
from nniquad.sim.metrics import settling_time
from nniquad.model.numeric import dynamics_function, mixer_function, param_vector
from nniquad.sim import SimOptions, SimParams, simulate
from nniquad.model.vehicle import PAPER_VEHICLE

V = PAPER_VEHICLE
#: A well-damped gain set (slowest pole -0.85 1/s) for short test horizons.
FAST = Gains(kp=8.0, Gamma=12.0, delta=0.3)


def _expm_xy(A6: np.ndarray, x0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Positions of the 6-state linear loop [x, x', z1, y, y', z2] by the matrix exponential."""
    Phi = expm(A6 * (t[1] - t[0]))
    out = np.empty((t.size, 6))
    out[0] = x0
    for k in range(1, t.size):
        out[k] = Phi @ out[k - 1]
    return out[:, [0, 3]]


# ------------------------------------------------------------------------------ linear, reduced


@pytest.mark.parametrize("gains", [PAPER_GAINS, FAST], ids=["paper", "fast"])
def test_linear_matches_matrix_exponential(gains):
    """RK4 at 1 ms against expm of the closed-loop A of nniquad.analysis.reduced_loop: within 1e-6 m over 30 s."""
    tr = simulate(V, gains, SimOptions(model="linear", horizon_s=30.0))[0]
    A6 = ReducedLoop(V.m, gains).closed_loop_A()
    ref = _expm_xy(A6, np.array([2.0, 0, 0, -1.5, 0, 0]), tr.t)
    assert np.max(np.abs(tr.xy - ref)) < 1e-6


def test_reduced_limits_the_commanded_tilt_exactly_and_equals_linear_below_it():
    o = SimOptions(model="reduced", horizon_s=5.0)
    tr = simulate(V, PAPER_GAINS, o)[0]
    # kp |xi0| = 12.5 m/s^2 > g tan 30 = 5.66 m/s^2: the limit is active at the start
    assert tr.cmd_tilt_deg[0] == pytest.approx(30.0, abs=1e-9)
    assert np.max(tr.cmd_tilt_deg) <= 30.0 + 1e-9
    assert np.max(np.hypot(*tr.a_cmd.T)) <= V.g * math.tan(math.radians(30.0)) * (1 + 1e-12)
    lin = simulate(V, PAPER_GAINS, o.with_(model="linear"))[0]
    assert np.max(lin.cmd_tilt_deg) > 50.0
    # from 1 % of the initial state the limit never acts, so reduced == linear to round-off
    small = o.with_(xi0=(0.02, -0.015))
    a = simulate(V, PAPER_GAINS, small)[0]
    b = simulate(V, PAPER_GAINS, small.with_(model="linear"))[0]
    assert np.max(np.abs(a.xy - b.xy)) < 1e-12


# ------------------------------------------------------------------------------ full vehicle


def test_factored_dynamics_equals_generated_exact_model():
    """The factored evaluation (numeric 3x3 solve) equals numeric.dynamics_function('exact')."""
    f, ref = sim.vehicle_dynamics(), dynamics_function("exact")
    rng = np.random.default_rng(3)
    p = param_vector(V)
    for _ in range(100):
        x = rng.normal(size=12)
        x[[6, 8]] = rng.uniform(-1.3, 1.3, 2)
        u = np.r_[rng.uniform(0, 10), rng.normal(scale=0.3, size=3)]
        om = rng.normal(scale=200)
        a, b = np.asarray(f(x, u, om, p)).ravel(), np.asarray(ref(x, u, om, p)).ravel()
        assert np.max(np.abs(a - b)) <= 1e-11 * np.max(np.abs(b))


@pytest.mark.parametrize("lag", [False, True], ids=["no-lag", "motor-lag"])
def test_full_rk4_matches_solve_ivp(lag):
    """RK4 (1 ms) against DOP853 (rtol 1e-11) on the same right-hand side, 4 s from the paper's state.

    The run saturates the rotors and the tilt limit (kinks in the right-hand
    side), which caps RK4 near first order across each kink; measured error
    ~2e-6 m without and ~2e-5 m with motor lag at 1 ms.  Bound: 1e-4 m, far
    below anything the metrics resolve (the settling band is 5 cm).
    """
    o = SimOptions(model="full", horizon_s=4.0, motor_lag=lag)
    tr = simulate(V, PAPER_GAINS, o)[0]
    if not lag:  # saturation really is exercised (with lag the motors filter the short saturated command)
        w = tr.rotor_speeds  # a rotor at either limit (the collective is kept, so usually 0 first)
        assert np.max(w) == pytest.approx(V.omega_max) or np.min(w) == pytest.approx(0.0, abs=1e-9)
    P = SimParams.from_options(V, PAPER_GAINS, o).vector()
    f = sim.rhs_function("full")
    e = np.zeros(len(sim.EXO_FIELDS))
    sol = solve_ivp(lambda t, x: np.asarray(f(x, e, P)).ravel(), (0, 4.0), tr.state[0], method="DOP853",
                    rtol=1e-11, atol=1e-12, t_eval=tr.t)
    assert sol.success
    assert np.max(np.abs(tr.xy - sol.y[[0, 2]].T)) < 1e-4
    assert np.max(np.abs(tr.state[:, 6:12:2] - sol.y[6:12:2].T)) < 1e-4  # angles [rad]


def test_full_small_amplitude_is_linear_loop_with_attitude_lag():
    """Near hover the full vehicle is the linear loop with the attitude loop's lag in series.

    Linearising: x'' = -g theta, theta_d = -a_x/g, theta'' = w^2 (theta_d - theta) - 2 zeta w q,
    so the actual acceleration a obeys a'' = w^2 (a_cmd - a) - 2 zeta w a' (same for y with phi).
    The neglected terms are quadratic (tan vs angle, thrust tilt compensation, gyroscopic and
    altitude coupling), so the relative error must be ~amplitude: measured 1.4e-6 at 1 % of the
    paper's initial state and 4x smaller at half that.  The plain linear model differs by
    ~50 % after 10 s: the lag destabilises the paper's lightly damped loop.
    """
    w, z = InnerLoopGains().attitude_wn_rad_s, InnerLoopGains().attitude_zeta
    kp, G, d, m = PAPER_GAINS.kp, PAPER_GAINS.Gamma, PAPER_GAINS.delta, V.m
    A5 = np.array([[0, 1, 0, 0, 0], [0, 0, 0, 1, 0], [G, 0, -G * d, 0, 0], [0, 0, 0, 0, 1],
                   [-kp * w**2, 0, w**2 / m, -w**2, -2 * z * w]])
    rel = []
    for scale in (0.01, 0.005):
        xi0 = (2.0 * scale, -1.5 * scale)
        tr = simulate(V, PAPER_GAINS, SimOptions(model="full", horizon_s=10.0, xi0=xi0))[0]
        Phi = expm(A5 * 0.01)
        ref = np.empty((tr.t.size, 2))
        for axis in range(2):
            s = np.array([xi0[axis], 0, 0, 0, 0])
            for k in range(tr.t.size):
                ref[k, axis] = s[0]
                s = Phi @ s
        rel.append(np.max(np.abs(tr.xy - ref)) / math.hypot(*xi0))
        if scale == 0.01:
            lin = simulate(V, PAPER_GAINS, SimOptions(model="linear", horizon_s=10.0, xi0=xi0))[0]
            assert np.max(np.abs(tr.xy - lin.xy)) / math.hypot(*xi0) > 0.2
    assert rel[0] < 1e-5
    assert 3.0 < rel[0] / rel[1] < 5.0  # quadratic nonlinearity, not a model mismatch


def test_lag_makes_paper_gains_unstable_but_fast_attitude_recovers_linear():
    """Eigenvalues of the linear loop + attitude lag: unstable at 25 rad/s, stable at 300 rad/s."""
    kp, G, d, m = PAPER_GAINS.kp, PAPER_GAINS.Gamma, PAPER_GAINS.delta, V.m

    def growth(w, z=0.8):
        A5 = np.array([[0, 1, 0, 0, 0], [0, 0, 0, 1, 0], [G, 0, -G * d, 0, 0], [0, 0, 0, 0, 1],
                       [-kp * w**2, 0, w**2 / m, -w**2, -2 * z * w]])
        return np.max(np.linalg.eigvals(A5).real)

    assert growth(25.0) > 0.03 and growth(300.0) < -0.01
    xi0 = (0.02, -0.015)
    o = SimOptions(model="full", horizon_s=20.0, xi0=xi0)
    slow = simulate(V, PAPER_GAINS, o)[0]
    fast = simulate(V, PAPER_GAINS, o.with_(inner=InnerLoopGains(attitude_wn_rad_s=300.0)))[0]
    d_slow = np.hypot(*slow.xy[-300:].T).max()
    d_fast = np.hypot(*fast.xy[-300:].T).max()
    assert d_slow > 1.5 * math.hypot(*xi0) and d_fast < math.hypot(*xi0)


def test_attitude_loop_converges_with_saturated_rotors():
    """A 30 deg tilt step (command held at the limit) with the rotor limit active converges.

    Far from the origin the horizontal command stays on the tilt limit in a
    fixed direction; the 30 deg step needs ~3x the torque the rotors can give at
    hover, so the allocation saturates.  Also with an aggressive attitude loop.
    """
    for inner in (InnerLoopGains(), InnerLoopGains(attitude_wn_rad_s=60.0, attitude_zeta=0.7)):
        o = SimOptions(model="full", horizon_s=2.0, xi0=(200.0, -150.0), inner=inner)
        tr = simulate(V, PAPER_GAINS, o)[0]
        assert np.all(np.isfinite(tr.state))
        # saturated: with the collective kept at hover the pair hits the lower limit (0) first
        assert np.max(tr.rotor_speeds) <= V.omega_max
        assert np.min(tr.rotor_speeds) == pytest.approx(0.0, abs=1e-9)
        late = tr.t >= 1.0
        assert np.all(np.abs(tr.cmd_tilt_deg[late] - 30.0) < 1e-6)
        assert np.max(np.abs(tr.tilt_deg[late] - 30.0)) < 0.5
        # yaw gives way first while the rotors saturate, then the yaw hold brings it back
        # (0.12 rad with the collective kept at hover: the saturated pair leaves yaw less room)
        assert np.max(np.abs(tr.psi)) < 0.15 and abs(tr.psi[-1]) < 1e-4
        assert np.max(np.abs(tr.z_ned)) < 0.05  # altitude hold through the manoeuvre [m]


def test_allocation_inverts_the_mixer_and_keeps_priorities():
    """Below saturation the allocation is the mixer's exact inverse; at saturation yaw gives way first."""
    u1s, tau = ca.SX.sym("u1"), ca.SX.sym("tau", 3)
    w, T = allocate(u1s, tau, param_vector(V), V.omega_max)
    alloc = ca.Function("alloc", [u1s, tau], [w, T])
    mixer = mixer_function()
    p = param_vector(V)
    hover = V.m * V.g
    demand = (hover, np.array([0.05, -0.08, 0.004]))
    w_cmd, _ = alloc(*demand)
    u, _ = mixer(w_cmd, p)
    np.testing.assert_allclose(np.asarray(u).ravel(), np.r_[demand[0], demand[1]], rtol=1e-12, atol=1e-15)
    t_max = V.b * V.omega_max**2
    # large pitch plus yaw: yaw is cut first, pitch kept, thrust kept
    pitch = 0.45  # N m, feasible at hover (max 2 l min(c, Tmax - c) = 0.552)
    yaw = 0.05  # N m, not feasible on top of that pitch torque
    w_cmd, T = alloc(hover, np.array([0.0, pitch, yaw]))
    u, _ = mixer(w_cmd, p)
    u = np.asarray(u).ravel()
    T = np.asarray(T).ravel()
    assert np.all(T >= -1e-15) and np.all(T <= t_max * (1 + 1e-12))
    assert u[2] == pytest.approx(pitch, rel=1e-12) and u[0] == pytest.approx(hover, rel=1e-12)
    assert 0 < u[3] < 0.9 * yaw
    # infeasible roll and pitch: scaled together (direction kept), collective kept (it holds altitude)
    w_cmd, T = alloc(hover, np.array([2.0, -1.0, 0.0]))
    u = np.asarray(mixer(w_cmd, p)[0]).ravel()
    assert u[1] / u[2] == pytest.approx(-2.0, rel=1e-9)
    assert u[0] == pytest.approx(hover, rel=1e-12)
    assert np.min(np.asarray(T)) == pytest.approx(0.0, abs=1e-12)  # the pair uses all the room below hover


def test_batch_equals_single_runs_and_per_run_exogenous_inputs():
    o = SimOptions(model="full", horizon_s=1.0, noise_sigma_m=0.01)
    gains = [PAPER_GAINS, FAST, Gains(kp=6.0, Gamma=100.0, delta=0.5)]
    res = simulate(V, gains, o)
    for b, g in enumerate(gains):
        one = simulate(V, g, o)[0]
        assert np.max(np.abs(res.xy[b] - one.xy)) < 1e-12
        assert res.metrics()[b] == one.metrics()
    # per-run exogenous inputs (Monte Carlo): run b with seed b equals a single run with seed b
    P = np.stack([SimParams.from_options(V, FAST, o).vector()] * 2)
    x0 = np.stack([sim.initial_state("full", SimParams.from_vector(P[0]))] * 2)
    E = np.stack([sim.exogenous_inputs(o, seed=s) for s in (0, 7)])
    X, _ = sim.run_batch("full", P, x0, E, steps_per_sample=o.steps_per_sample, n_samples=o.n_samples)
    one = simulate(V, FAST, o.with_(seed=7))[0]
    assert np.max(np.abs(X[1] - one.state)) < 1e-12
    assert np.max(np.abs(X[0] - X[1])) > 1e-4


def test_settling_batch_and_progress():
    o = SimOptions(model="linear", horizon_s=15.0)
    seen = []
    res = simulate(V, [FAST, PAPER_GAINS], o, progress=seen.append)
    s = res.settling_s
    assert seen[-1] == pytest.approx(1.0) and seen == sorted(seen)
    assert s[0] == pytest.approx(res.metrics()[0].settling_s, abs=1e-12)
    assert math.isnan(s[1]) and res.metrics()[1].settling_s is None  # paper gains: ~224 s


# ------------------------------------------------------------------------------ simulate -> metrics


def test_metrics_of_a_hand_made_trajectory():
    """Trajectory.metrics on signals with known answers: exponential decay and a damped cosine."""
    t = np.linspace(0, 10, 10001)
    o = SimOptions(model="linear", horizon_s=10.0, output_dt_s=0.001, dt_s=0.001)
    state = np.zeros((t.size, 8))
    decay = np.exp(-t)
    state[:, 0], state[:, 2] = 2 * decay, -1.5 * decay
    out = np.zeros((t.size, 5))
    tr = sim.Trajectory("linear", o, FAST, V, t, state, out, sim.STATE_NAMES["linear"], sim.OUTPUT_NAMES["linear"])
    m = tr.metrics()
    assert m.settling_s == pytest.approx(math.log(50), abs=1e-5)  # 2 % band of exp(-t)
    assert m.overshoot_pct == 0.0 and not m.diverged and m.peak_tilt_deg == 0.0
    # damped cosine along xi0: the first undershoot is at w t* = pi - atan(s/w),
    # of size exp(-s t*) cos(atan(s/w)) (47.03 % here)
    s_, w_ = 0.5, 2.0
    c = np.exp(-s_ * t) * np.cos(w_ * t)
    state[:, 0], state[:, 2] = 2 * c, -1.5 * c
    tr = sim.Trajectory("linear", o, FAST, V, t, state, out, sim.STATE_NAMES["linear"], sim.OUTPUT_NAMES["linear"])
    t_star = (math.pi - math.atan(s_ / w_)) / w_
    expect = 100 * math.exp(-s_ * t_star) * math.cos(math.atan(s_ / w_))
    assert tr.metrics().overshoot_pct == pytest.approx(expect, rel=1e-6)


def test_simulated_settling_matches_independent_fine_grid():
    """Settling from the 10 ms trajectory vs the metric on a 1 ms expm solution: within 5 ms."""
    tr = simulate(V, FAST, SimOptions(model="linear", horizon_s=20.0))[0]
    t = np.arange(0, 20.0 + 1e-9, 1e-3)
    ref = _expm_xy(ReducedLoop(V.m, FAST).closed_loop_A(), np.array([2.0, 0, 0, -1.5, 0, 0]), t)
    ts = settling_time(t, ref)
    m = tr.metrics()
    assert ts is not None and 2.0 < ts < 15.0
    assert m.settling_s == pytest.approx(ts, abs=5e-3)


# ------------------------------------------------------------------------------ options


def test_noise_is_seeded_sampled_and_held():
    o = SimOptions(model="linear", horizon_s=1.0, noise_sigma_m=0.01, noise_rate_hz=50.0)
    E = sim.exogenous_inputs(o)
    assert E.shape == (1000, len(sim.EXO_FIELDS)) and np.count_nonzero(E[:, 2]) == 50  # a new sample every 20 steps
    assert np.all(E[1:20, 0] == E[0, 0]) and E[20, 0] != E[0, 0]
    np.testing.assert_array_equal(E, sim.exogenous_inputs(o))
    assert not np.array_equal(E, sim.exogenous_inputs(o.with_(seed=1)))
    a, b = simulate(V, FAST, o)[0], simulate(V, FAST, o)[0]
    np.testing.assert_array_equal(a.state, b.state)
    clean = simulate(V, FAST, o.with_(noise_sigma_m=0.0))[0]
    assert 1e-5 < np.max(np.abs(a.xy - clean.xy)) < 0.05
    # the held measurement only changes at sample instants (every 20 ms = 2 output samples)
    held = a.state[:, 6]
    assert np.all(np.diff(held)[1::2] == 0.0) and np.all(np.diff(held)[0::2] != 0.0)


@pytest.mark.parametrize("rate_hz", [50.0, 30.0, 100.0, 7.0])
def test_noise_sample_instants_over_a_long_run(rate_hz):
    """Sample j is taken at the first step k with k dt >= j / rate, for every j of a 20 s run.

    The reference is exact rational arithmetic (k_j = ceil(j / (rate dt))), so a
    floating-point floor that lands one step late at some j (e.g. 50 Hz, j = 3 ...)
    fails here, while the sample count alone would still be right.
    """
    from fractions import Fraction

    o = SimOptions(model="linear", horizon_s=20.0, noise_sigma_m=0.01, noise_rate_hz=rate_hz)
    E = sim.exogenous_inputs(o)
    n = E.shape[0]
    steps_per_sample = 1 / (Fraction(rate_hz).limit_denominator(1000) * Fraction(o.dt_s).limit_denominator(10**6))
    expected = []
    j = 0
    while True:
        k = math.ceil(j * steps_per_sample)
        if k >= n:
            break
        expected.append(k)
        j += 1
    np.testing.assert_array_equal(np.flatnonzero(E[:, 2]), expected)
    # the noise value changes exactly at those instants and is held in between
    changes = np.flatnonzero(np.any(np.diff(E[:, 0:2], axis=0) != 0.0, axis=1)) + 1
    np.testing.assert_array_equal(changes, expected[1:])


def test_tilt_jitter_under_noise_is_reported():
    o = SimOptions(model="reduced", horizon_s=20.0, noise_sigma_m=0.005, noise_rate_hz=50.0)
    m = simulate(V, FAST, o)[0].metrics()
    assert m.settling_s is not None and m.tilt_jitter_rms_deg is not None and m.tilt_jitter_rms_deg > 0


def test_constant_wind_gives_the_steady_offset():
    """Equilibrium of xi'' = -kp xi + z/m + F/m, z = xi/delta: xi = F / (m kp - 1/delta)."""
    F = (0.2, -0.1)
    tr = simulate(V, FAST, SimOptions(model="linear", horizon_s=30.0, wind_N=F))[0]
    expect = np.array(F) / (V.m * FAST.kp - 1.0 / FAST.delta)
    np.testing.assert_allclose(tr.xy[-1], expect, atol=1e-6)


def test_full_with_mass_error_gust_and_motor_lag_holds_altitude():
    o = SimOptions(model="full", horizon_s=8.0, true_mass_kg=0.55, gust_N=0.05, motor_lag=True, seed=3)
    tr = simulate(V, FAST, o)[0]
    m = tr.metrics()
    assert not m.diverged and np.all(np.isfinite(tr.state))
    assert abs(tr.z_ned[-1]) < 0.01  # the altitude integral removes the 10 % mass error's offset
    assert m.altitude_dev_m < 0.2


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"horizon_s": -1.0}, "horizon"),
        ({"horizon_s": float("nan")}, "horizon"),
        ({"noise_sigma_m": -0.1}, "noise sigma"),
        ({"noise_rate_hz": 0.0}, "rate"),
        ({"noise_rate_hz": 5000.0}, "rate"),
        ({"dt_s": 0.0}, "time step"),
        ({"output_dt_s": 0.0015}, "multiple"),
        ({"model": "quantum"}, "unknown model"),
        ({"tilt_limit_deg": 95.0}, "tilt limit"),
        ({"xi0": (1.0,)}, "xi0"),
        ({"true_mass_kg": 0.0}, "true mass"),
        ({"seed": -1}, "seed"),
    ],
)
def test_bad_options_raise_one_line_errors(kwargs, message):
    with pytest.raises(SimulationError, match=message) as info:
        SimOptions(**kwargs)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("gains", [(float("nan"), 160.0, 0.6), (5.0, float("inf"), 0.6), (5.0, 160.0, -1.0),
                                   {"kp": 5.0, "Gamma": 160.0}])
def test_bad_gains_raise_gain_error(gains):
    with pytest.raises(GainError):
        simulate(V, gains, SimOptions(model="linear", horizon_s=1.0))[0]


def test_step_too_large_for_controller_pole():
    with pytest.raises(SimulationError, match="Gamma\\*delta"):
        simulate(V, Gains(kp=5.0, Gamma=5000.0, delta=1.0), SimOptions(model="linear", horizon_s=1.0))[0]


def test_compile_failure_falls_back_to_the_vm(monkeypatch, tmp_path):
    x = ca.SX.sym("x", 2)
    fn = ca.Function("nniquad_test_fallback", [x], [ca.sin(x) * 2])
    monkeypatch.delenv("NNIQUAD_NO_JIT", raising=False)
    monkeypatch.setenv("NNIQUAD_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "/nonexistent/compiler")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = sim.codegen.compile_function(fn)
    assert any("CasADi VM" in str(w.message) for w in caught)
    assert float(out([1.0, 2.0])[0]) == pytest.approx(2 * math.sin(1.0))


@pytest.mark.parametrize("damage", ["truncated", "no record"])
def test_a_damaged_compiled_object_is_compiled_again_not_loaded(monkeypatch, tmp_path, damage):
    """The compiled-C cache follows the code cache's rule: an object that does not match its record is rebuilt."""
    if shutil.which(os.environ.get("CC", "gcc")) is None:
        pytest.skip("no C compiler")
    x = ca.SX.sym("x", 2)
    fn = ca.Function("nniquad_test_intact", [x], [ca.sin(x) * 2])
    monkeypatch.delenv("NNIQUAD_NO_JIT", raising=False)
    monkeypatch.setenv("NNIQUAD_CACHE_DIR", str(tmp_path))
    sim.codegen.compile_function(fn)
    (so,) = tmp_path.glob("nniquad_test_intact_*.so")
    good = so.read_bytes()
    if damage == "truncated":
        so.write_bytes(good[: len(good) // 3])
    else:
        so.with_name(so.name + ".sha256").unlink()
    loaded = []
    real = ca.external
    monkeypatch.setattr(ca, "external", lambda name, path: loaded.append(Path(path).read_bytes()) or real(name, path))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no fallback to the VM: the object was rebuilt
        out = sim.codegen.compile_function(fn)
    # only the rebuilt object was handed to dlopen: complete, and the one its record describes
    assert len(loaded) == 1 and len(loaded[0]) == len(good)
    assert hashlib.sha256(loaded[0]).hexdigest().encode() == hashlib.sha256(so.read_bytes()).hexdigest().encode()
    assert codecache.read_entry(so.with_name(so.name + ".sha256"), so.stem.rsplit("_", 1)[-1]) == \
        hashlib.sha256(loaded[0]).hexdigest().encode()
    assert "compiled" in sim.codegen.compile_status()["nniquad_test_intact"]
    assert float(out([1.0, 2.0])[0]) == pytest.approx(2 * math.sin(1.0), rel=1e-12)


def test_trajectory_save_roundtrip(tmp_path):
    tr = simulate(V, FAST, SimOptions(model="reduced", horizon_s=0.5))[0]
    p = tr.save(tmp_path / "run.npz")
    with np.load(p) as data:
        np.testing.assert_array_equal(data["state"], tr.state)
        assert tuple(data["state_names"]) == tr.state_names
    c = tr.save(tmp_path / "run.csv")
    arr = np.loadtxt(c, delimiter=",", skiprows=1)
    assert arr.shape == (tr.t.size, 1 + tr.state.shape[1] + tr.outputs.shape[1])
    with pytest.raises(SimulationError):
        tr.save(tmp_path / "run.txt")


def test_params_vector_roundtrip_and_layout():
    p = SimParams.from_options(V, PAPER_GAINS, SimOptions(true_mass_kg=0.6))
    v = p.vector()
    assert v.size == len(sim.param_layout("nni"))
    assert SimParams.from_vector(v) == p
    names = [f.name for f in sim.param_layout("nni")]
    assert v[names.index("plant.m")] == 0.6 and v[names.index("nominal.m")] == V.m


def test_paper_figure_and_trajectory_plot(tmp_path):
    from nniquad.sim.plots import paper_figure, trajectory_plot

    runs = sim.paper_figure_runs(V, PAPER_GAINS, horizon_s=12.0)
    assert list(runs) == list(sim.MODELS)
    p = paper_figure(runs, tmp_path / "paper.png", zoom_s=2.0)
    q = trajectory_plot(runs["full"], tmp_path / "full.png")
    assert p.stat().st_size > 20_000 and q.stat().st_size > 20_000
    assert not list(tmp_path.glob("*.tmp"))


# ------------------------------------------------------------------------------ the one entry point


def test_simulation_result_holds_many_runs_with_named_signals(tmp_path):
    o = SimOptions(model="reduced", horizon_s=3.0)
    gains = [FAST, PAPER_GAINS, Gains(kp=6.0, Gamma=100.0, delta=0.5)]
    res = simulate(V, gains, o)
    assert len(res) == 3 and res.controller == "nni" and res.model == "reduced"
    assert res.states.shape == (3, res.t.size, len(sim.STATE_NAMES["reduced"]))
    assert res.xy.shape == (3, res.t.size, 2) and res.tilt_deg.shape == (3, res.t.size)
    np.testing.assert_array_equal(res.state("x"), res.xy[..., 0])
    np.testing.assert_array_equal(res.output("tilt_cmd"), res.outputs[:, :, 2])
    assert res.z_ned is None and res.altitude_lost is None
    with pytest.raises(SimulationError, match="no state"):
        res.state("nope")
    # a run view is a Trajectory of that run
    last = res[-1]
    assert isinstance(last, sim.Trajectory) and last.gains == gains[2] and last.params == res.params[2]
    np.testing.assert_array_equal(last.xy, res.xy[2])
    np.testing.assert_array_equal(res.tilt_deg[1], res[1].tilt_deg)
    assert [tr.gains for tr in res] == gains
    with pytest.raises(IndexError):
        res[3]
    # per-run metrics, and the vectorised settling times agree with them
    mets = res.metrics()
    assert mets == [tr.metrics() for tr in res]
    np.testing.assert_allclose(res.settling_s, [np.nan if m.settling_s is None else m.settling_s for m in mets])
    data = res.to_json()
    assert len(data["runs"]) == 3 and data["runs"][0]["gains"] == FAST.as_dict()
    assert "runs=3" in repr(res)
    fig = res.plot(tmp_path / "runs.png")
    assert (tmp_path / "runs.png").stat().st_size > 10_000 and len(fig.axes) == 2


def test_per_run_options_and_params_equal_separate_runs():
    """Option sets per run (tuner: inner-loop gains; Monte Carlo: seeds) and ready params, in one call."""
    o = SimOptions(model="full", horizon_s=1.0, noise_sigma_m=0.01)
    inners = [InnerLoopGains(), InnerLoopGains(attitude_wn_rad_s=40.0)]
    res = simulate(V, FAST, [o.with_(inner=i, seed=s) for i, s in zip(inners, (0, 5))])
    for b, (inner, seed) in enumerate(zip(inners, (0, 5))):
        one = simulate(V, FAST, o.with_(inner=inner, seed=seed))[0]
        np.testing.assert_array_equal(res.states[b], one.state)
    # ready parameter sets: a heavier plant, built by hand, equals the true-mass option
    p = SimParams.from_options(V, FAST, o).with_(plant={"m": 0.6})
    a = simulate(None, None, o, params=[p])
    b = simulate(V, FAST, o.with_(true_mass_kg=0.6))
    np.testing.assert_array_equal(a.states, b.states)
    assert a.vehicle is None and a.gains == (FAST,)
    with pytest.raises(GainError, match="not both"):
        simulate(V, FAST, o, params=[p])
    with pytest.raises(SimulationError, match="2 gain sets given for 3 runs"):
        simulate(V, [FAST, PAPER_GAINS], [o, o, o])
    with pytest.raises(SimulationError, match="share model"):
        simulate(V, FAST, [o, o.with_(horizon_s=2.0)])


def test_one_verdict_for_a_vehicle_that_falls():
    """A vehicle that cannot hover falls: altitude lost, in simulate's metrics and in the Monte Carlo verdict alike."""
    import nniquad.study as mc
    from nniquad.sim.verdicts import failure_reason

    o = SimOptions(model="full", horizon_s=3.0)
    heavy = SimParams.from_options(V, FAST, o).with_(plant={"m": 1.5 * V.max_thrust() / V.g})
    res = simulate(None, None, o, params=[heavy])
    m = res[0].metrics()
    assert m.altitude_dev_m > 10.0  # free fall for most of 3 s: ~ g t^2 / 2 less the remaining thrust
    # the vehicle is lost (diverged) through its altitude: the verdict names that cause
    assert m.diverged and not m.blew_up and m.altitude_lost and m.failure == "altitude lost"
    assert res.altitude_lost.tolist() == [True] and res.diverged.tolist() == [True]
    setup = mc.study_setup_from(V, FAST, horizon_s=3.0)
    s = mc.draw_scenario(0, 0, mc.DEFAULT_RANGES, setup).with_params(plant={"m": heavy.plant.m})
    assert mc.run_scenarios([s])[0].failure == failure_reason(False, True, False) == "altitude lost"


def test_step_too_large_for_the_motor_pole():
    with pytest.raises(SimulationError, match="motor time constant"):
        simulate(V, FAST, SimOptions(model="full", horizon_s=0.1, motor_lag=True, tau_motor_s=1e-9))
    # without motor lag the time constant is unused
    simulate(V, FAST, SimOptions(model="full", horizon_s=0.1, tau_motor_s=1e-9))


def test_parameter_layout_is_generated_from_the_typed_blocks():
    """Every entry is group.field of a typed block, with that field's unit; a block's new field would appear here."""
    from dataclasses import fields

    from nniquad.laws.registry import LAWS
    from nniquad.model.vehicle import UNITS, Vehicle

    # the frame enters as its index (a number) after the numeric fields
    vehicle = [f.name for f in fields(Vehicle) if f.name not in ("name", "frame")] + ["frame_index"]
    inner = [f.name for f in fields(InnerLoopGains)]
    for controller, block in ((name, law.gains_type) for name, law in LAWS.items()):
        layout = sim.param_layout(controller)
        names = [f.name for f in layout]
        expected = ([f"gains.{f.name}" for f in fields(block)] + [f"nominal.{n}" for n in vehicle]
                    + [f"inner.{n}" for n in inner] + [f"plant.{n}" for n in vehicle]
                    + [f"run.{f.name}" for f in fields(sim.RunSettings)])
        assert names == expected and len(set(names)) == len(names)
        units = {f.name: f.unit for f in layout}
        assert all(units[f"plant.{n}"] == UNITS[n] == units[f"nominal.{n}"] for n in vehicle[:-1])
        assert units["run.dt"] == "s" and units["run.tilt_limit"] == "rad"
    assert sim.param_layout("nni")[0].unit == "1/s^2" and sim.param_layout("pd_filtered")[2].unit == "s"
    # the vector holds the typed values at their names
    p = SimParams.from_options(V, Gains(4.0, 20.0, 0.8, kpy=3.0), SimOptions(tilt_limit_deg=20.0, wind_N=(0.1, 0.2)))
    values = dict(zip([f.name for f in p.layout], p.vector()))
    assert values["gains.kpy"] == 3.0 and values["gains.Gamma"] == 20.0 and values["nominal.Jz"] == V.Jz
    assert values["run.tilt_limit"] == pytest.approx(math.radians(20.0)) and values["run.wind_y"] == 0.2
    assert values["inner.attitude_wn_rad_s"] == InnerLoopGains().attitude_wn_rad_s


def test_batch_threads_follow_the_usable_cpus_and_do_not_change_results(monkeypatch):
    """The batch's thread count is the process's usable CPUs (affinity mask), not the machine's; a pool worker's
    cap (set_batch_threads) changes the threads only, never a number."""
    import os

    from nniquad.laws.nni import PAPER_GAINS, Gains
    from nniquad.model.vehicle import PAPER_VEHICLE
    from nniquad.resources import usable_cpu_count
    from nniquad.sim import SimOptions, simulate
    from nniquad.sim import runner

    if hasattr(os, "sched_getaffinity"):
        assert usable_cpu_count() <= len(os.sched_getaffinity(0))
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})  # a process restricted to one CPU
        assert usable_cpu_count() == 1 and runner.batch_threads(100) == 1
        monkeypatch.undo()
    gains = [PAPER_GAINS, Gains(4.0, 120.0, 0.7), Gains(6.0, 200.0, 0.5)]
    o = SimOptions(model="full", horizon_s=1.0)
    try:
        runner.set_batch_threads(1)
        assert runner.batch_threads(100) == 1
        one = simulate(PAPER_VEHICLE, gains, o)
        runner.set_batch_threads(2)
        assert runner.batch_threads(100) == 2 and runner.batch_threads(1) == 1
        two = simulate(PAPER_VEHICLE, gains, o)
    finally:
        runner.set_batch_threads(None)
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a.state, b.state)
    with pytest.raises(SimulationError, match="batch threads"):
        runner.set_batch_threads(0)


def test_batch_slices_cover_every_run_once_and_leave_the_callers_arrays_alone():
    """The runs are split into contiguous, nearly equal slices, one per thread; run_batch overwrites its own copy
    of the state after every segment, never the caller's x0 (a batch of 3 on 2 threads, against runs of one)."""
    from nniquad.laws.nni import PAPER_GAINS, Gains
    from nniquad.model.vehicle import PAPER_VEHICLE
    from nniquad.sim import SimOptions, SimParams
    from nniquad.sim import runner

    for B in range(1, 12):
        for threads in range(1, 5):
            parts = runner._thread_slices(B, threads)
            covered = [i for part in parts for i in range(part.start, part.stop)]
            sizes = [part.stop - part.start for part in parts]
            assert covered == list(range(B)) and len(parts) == min(B, threads) and max(sizes) - min(sizes) <= 1
    o = SimOptions(model="full", horizon_s=0.5)
    params = [SimParams.from_options(PAPER_VEHICLE, g, o) for g in (PAPER_GAINS, Gains(4.0, 120.0, 0.7),
                                                                      Gains(6.0, 200.0, 0.5))]
    P = np.stack([p.vector() for p in params])
    X0 = np.stack([runner.initial_state("full", p) for p in params])
    X0_before = X0.copy()
    E = runner.exogenous_inputs(o)
    try:
        runner.set_batch_threads(2)
        X, _ = runner.run_batch("full", P, X0, E, steps_per_sample=o.steps_per_sample, n_samples=o.n_samples)
    finally:
        runner.set_batch_threads(None)
    np.testing.assert_array_equal(X0, X0_before)
    for b in range(3):
        alone, _ = runner.run_batch("full", P[b:b + 1], X0[b:b + 1], E, steps_per_sample=o.steps_per_sample,
                                    n_samples=o.n_samples)
        np.testing.assert_array_equal(X[b], alone[0])
        assert np.all(np.isfinite(X[b])) and not np.array_equal(X[b, -1], X0[b])
