"""The linearised cascade against finite differences of the nonlinear simulator and the reduced loop."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from nniquad.analysis.linearised_cascade import linearise, linearise_cascade
from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.laws.nni import PAPER_GAINS, Gains
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.laws.pd_velocity import PDGains
from nniquad.errors import CascadeError, NniquadError
from nniquad.model.numeric import mixer_function, param_vector
from nniquad.model.vehicle import PAPER_VEHICLE
from nniquad.sim import EXO_FIELDS, STATE_NAMES, SimOptions, SimParams, initial_state, rhs_function, step_function

GAINS = Gains(kp=13.148341568334407, Gamma=25.27258951977003, delta=0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56021438245625, attitude_zeta=1.1320049751084362,
                       attitude_accel_limit_rad_s2=31.13986455385077)


@pytest.fixture(scope="module")
def cascade():
    return linearise_cascade(PAPER_VEHICLE, GAINS, INNER)


NO_EXO = np.zeros(len(EXO_FIELDS))


def _params(motor_lag: bool, inner=INNER, gains=GAINS) -> SimParams:
    opts = SimOptions(model="full", motor_lag=motor_lag, sample_hold=False, inner=inner)
    return SimParams.from_options(PAPER_VEHICLE, gains, opts)


def _fd_jacobian(fun, x0: np.ndarray, idx: list[int], h: float = 1e-6) -> np.ndarray:
    """Central finite differences of fun (numpy in, numpy out) over the states idx."""
    cols = []
    for i in idx:
        d = np.zeros_like(x0)
        d[i] = h
        cols.append((fun(x0 + d) - fun(x0 - d)) / (2 * h))
    return np.array(cols).T


def _kept(cascade, motor_lag=True):
    names = STATE_NAMES["full"]
    return [names.index(n) for n in cascade.closed_loop_states]


def test_hover_is_an_equilibrium_of_the_nonlinear_loop(cascade):
    p = _params(True)
    x0 = initial_state("full", p, (0.0, 0.0))
    f = np.asarray(rhs_function("full")(x0, NO_EXO, p.vector())).ravel()
    assert np.max(np.abs(f)) == 0.0
    assert cascade.lin.residual == 0.0
    # one RK4 step leaves it unchanged too
    sample = NO_EXO.copy()
    sample[EXO_FIELDS.index("sample_flag")] = 1.0
    xn = np.asarray(step_function("full")(x0, sample, p.vector())).ravel()
    assert np.max(np.abs(xn - x0)) < 1e-12


def test_closed_loop_matrix_matches_finite_differences_of_the_rhs(cascade):
    # continuous measurement (sample_hold off): a second path through the simulator than the split
    p = _params(True)
    x0 = initial_state("full", p, (0.0, 0.0))
    f = rhs_function("full")
    idx = _kept(cascade)
    fun = lambda x: np.asarray(f(x, NO_EXO, p.vector())).ravel()[idx]  # noqa: E731
    J_fd = _fd_jacobian(fun, x0, idx)
    A = cascade.A
    scale = np.maximum(np.abs(A), 1.0)
    assert np.max(np.abs(A - J_fd) / scale) < 1e-5


def test_one_rk4_step_matches_the_matrix_exponential(cascade):
    p = _params(True)
    x0 = initial_state("full", p, (0.0, 0.0))
    step = step_function("full")
    idx = _kept(cascade)
    e = NO_EXO  # no sample flag: held states unused with sample_hold off
    fun = lambda x: np.asarray(step(x, e, p.vector())).ravel()[idx]  # noqa: E731
    Phi_fd = _fd_jacobian(fun, x0, idx)
    # one RK4 step of x' = A x is exactly the degree-4 Taylor polynomial of exp(A dt): that is what the
    # simulator's step must reproduce (an independent path: A from the linearisation, Phi_fd from the step)
    Adt = cascade.A * p.run.dt
    Phi_rk4, term = np.eye(len(Adt)), np.eye(len(Adt))
    for k in range(1, 5):
        term = term @ Adt / k
        Phi_rk4 = Phi_rk4 + term
    assert np.max(np.abs(Phi_rk4 - Phi_fd) / np.maximum(np.abs(Phi_rk4), 1.0)) < 1e-6
    # and it is the matrix exponential up to RK4's O(dt^5) truncation (measured 1.2e-5 at the largest entry:
    # the rotor reaction torque adds fast yaw/motor coupling, spectral radius of A dt about 0.19)
    Phi = sla.expm(Adt)
    assert np.max(np.abs(Phi - Phi_fd) / np.maximum(np.abs(Phi), 1.0)) < 1e-4


def test_controller_blocks_are_the_closed_form_law(cascade):
    g, m = GAINS, PAPER_VEHICLE.m
    np.testing.assert_allclose(cascade.A_k, -g.Gamma * g.delta * np.eye(2), rtol=1e-12)
    np.testing.assert_allclose(cascade.B_k, g.Gamma * np.eye(2), rtol=1e-12)
    np.testing.assert_allclose(cascade.C_k, np.eye(2) / m, rtol=1e-10)
    np.testing.assert_allclose(cascade.D_k, -g.kp * np.eye(2), rtol=1e-10)


def test_plant_without_motor_lag_matches_the_lag_free_simulator():
    cas = linearise_cascade(PAPER_VEHICLE, GAINS, INNER, motor_lag=False)
    p = _params(False)
    x0 = initial_state("full", p, (0.0, 0.0))
    f = rhs_function("full")
    idx = _kept(cas)
    fun = lambda x: np.asarray(f(x, NO_EXO, p.vector())).ravel()[idx]  # noqa: E731
    J_fd = _fd_jacobian(fun, x0, idx)
    assert np.max(np.abs(cas.A - J_fd) / np.maximum(np.abs(cas.A), 1.0)) < 1e-5


def test_allocation_jacobian_inverts_the_mixer(cascade):
    import casadi as ca

    w = ca.SX.sym("w", 4)
    u, _ = mixer_function()(w, param_vector(PAPER_VEHICLE))
    J = ca.Function("J", [w], [ca.jacobian(u, w)])
    w_hover = cascade.lin.x_eq[[STATE_NAMES["full"].index(f"w{i}") for i in range(1, 5)]]
    np.testing.assert_allclose(np.asarray(J(w_hover)) @ cascade.M_alloc, np.eye(4), atol=1e-9)


@pytest.mark.parametrize("gains", [GAINS, PAPER_GAINS])
def test_fast_attitude_loop_without_lag_recovers_the_reduced_poles(gains):
    red = ReducedLoop(PAPER_VEHICLE.m, gains).poles_and_damping().poles
    errors = []
    for wn in (300.0, 3000.0):
        cas = linearise_cascade(PAPER_VEHICLE, gains, InnerLoopGains(attitude_wn_rad_s=wn), motor_lag=False)
        ev = np.linalg.eigvals(cas.A)
        # each reduced pole is matched by the nearest cascade eigenvalue (distinct ones, greedy)
        free = list(ev)
        err = 0.0
        for lam in red:
            j = int(np.argmin([abs(mu - lam) for mu in free]))
            err = max(err, abs(free.pop(j) - lam) / abs(lam))
        errors.append(err)
    assert errors[1] < 2e-3
    assert errors[1] < errors[0] / 5  # the gap closes as the attitude loop gets faster (~1/wn)


def test_bad_requests_raise_the_cascade_error(cascade):
    # errors by kind: every refusal of the cascade is a CascadeError, hence a one-line NniquadError in the CLI
    assert issubclass(CascadeError, NniquadError)
    with pytest.raises(CascadeError, match="finite positive"):
        cascade.closed_loop(0.0)
    with pytest.raises(CascadeError, match="controller variant"):
        cascade.closed_loop(100.0, variant="analogue")
    with pytest.raises(CascadeError, match="break point"):
        cascade.closed_loop(None).loop("yaw")
    with pytest.raises(CascadeError, match="'linear' or 'full'"):
        linearise("reduced", _params(True))
    pd = SimParams.from_options(PAPER_VEHICLE, PDGains(kp=4.0, kd=3.0), SimOptions(model="full"))
    with pytest.raises(CascadeError, match="law of the NI structure"):
        linearise("full", pd)


def test_a_mass_error_is_not_an_equilibrium():
    # the plant heavier than the controller's model: hover thrust is short, so f(x_hover) != 0
    p = _params(True).with_(plant={"m": 1.1 * PAPER_VEHICLE.m})
    with pytest.raises(CascadeError, match="not an equilibrium"):
        linearise("full", p)


@pytest.mark.parametrize("delay", [0.005, 0.0025, 0.3])
@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_pade_delay_is_python_controls_realisation(delay, order):
    """pade_delay against python-control's pade + tf -> ss, and the approximant against e^{-jωτ} at low ω."""
    import control as ct

    from nniquad.analysis.loops import pade_delay

    A, B, C, D = pade_delay(delay, order)
    ref = ct.ss(ct.tf(*ct.pade(delay, order)))
    for got, want in ((A, ref.A), (B, ref.B), (C, ref.C), (D, ref.D)):
        np.testing.assert_allclose(got, np.asarray(want), rtol=1e-13, atol=1e-13 * np.max(np.abs(want)))
    w = 0.05 / delay  # well inside the approximant's band: error O((ωτ)^(2n+1))
    resp = (C @ np.linalg.solve(1j * w * np.eye(order) - A, B) + D)[0, 0]
    assert abs(resp - np.exp(-1j * w * delay)) < 1e-3 ** order
    assert abs(abs(resp) - 1.0) < 1e-12  # all-pass


@pytest.mark.parametrize("n", [1, 7, 256, 2 * 256 + 3])
def test_evaluate_map_equals_casadis_own_map(n):
    """evaluate_map (buffers, blocks of points) against fn.map(n) called on numpy and converted by CasADi."""
    import casadi as ca

    from nniquad.analysis.batch_eval import evaluate_map

    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    f = ca.vertcat(x[0] * p[0], ca.sin(x[2]) + p[1] * x[1] ** 2, x[0])
    fn = ca.Function("f", [x, p], [f, ca.jacobian(f, x), ca.jacobian(f, p)[:2, :]])
    rng = np.random.default_rng(n)
    X, P = rng.standard_normal((3, n)), rng.standard_normal((2, n))
    got = evaluate_map(fn, n, X, P)
    want = [np.asarray(o, float) for o in fn.map(n)(X, P)]
    for g, w, j in zip(got, want, range(3)):
        rows, cols = fn.size_out(j)
        assert g.shape == (n, rows, cols)
        # fn.map's output holds the points' blocks side by side: (rows, n * cols)
        np.testing.assert_array_equal(g, w.reshape(rows, n, cols).transpose(1, 0, 2))
    with pytest.raises(ValueError, match="shape"):
        evaluate_map(fn, n, X[:, :-1] if n > 1 else X[:2], P)
