"""Sampled loops: ZOH against closed forms and scipy, the discrete cascade against the simulator, the LMI."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal as sig

from nniquad.analysis.linearised_cascade import linearise_cascade
from nniquad.analysis.sampled import discrete_lyapunov_decay, nni_zoh_closed_form, sampled_cascade, \
    sampled_reduced_loop, zoh
from nniquad.control.discrete import DiscreteNNI
from nniquad.laws.nni import Gains
from nniquad.control.inner_gains import InnerLoopGains
from nniquad.errors import SolverError
from nniquad.model.vehicle import PAPER_VEHICLE
from nniquad.sim import SimOptions, simulate

GAINS = Gains(kp=13.148341568334407, Gamma=25.27258951977003, delta=0.19046572101699574)
INNER = InnerLoopGains(attitude_wn_rad_s=101.56021438245625, attitude_zeta=1.1320049751084362,
                       attitude_accel_limit_rad_s2=31.13986455385077)


def test_zoh_matches_closed_form_and_scipy():
    T = 0.01
    a, b = nni_zoh_closed_form(GAINS.Gamma, GAINS.delta, T)
    Phi, Gam = zoh([[-GAINS.Gamma * GAINS.delta]], [[GAINS.Gamma]], T)
    assert Phi[0, 0] == pytest.approx(a, rel=1e-14)
    assert Gam[0, 0] == pytest.approx(b, rel=1e-12)
    A = np.array([[0.0, 1.0], [-4.0, -0.3]])
    B = np.array([[0.0], [2.0]])
    Ad, Bd, *_ = sig.cont2discrete((A, B, np.eye(2), np.zeros((2, 1))), T, method="zoh")
    P2, G2 = zoh(A, B, T)
    np.testing.assert_allclose(P2, Ad, rtol=1e-12)
    np.testing.assert_allclose(G2, Bd, rtol=1e-12)
    ctrl = DiscreteNNI.from_gains(GAINS, PAPER_VEHICLE.m, PAPER_VEHICLE.g, 1 / T, 30.0)
    np.testing.assert_allclose(ctrl.A, a * np.eye(2), rtol=1e-14)
    np.testing.assert_allclose(ctrl.B, b * np.eye(2), rtol=1e-14)


@pytest.fixture(scope="module")
def cascade():
    return linearise_cascade(PAPER_VEHICLE, GAINS, INNER)


def test_held_sampled_cascade_matches_the_nonlinear_simulator(cascade):
    # small displacement: the simulator (RK4 at 1 ms, measurement sampled and held at 100 Hz,
    # continuous controller) against the exact discretisation of the linearised cascade
    xi0 = (2e-4, -1.5e-4)
    opts = SimOptions(model="full", horizon_s=1.0, output_dt_s=0.01, motor_lag=True, sample_hold=True,
                      noise_rate_hz=100.0, xi0=xi0, inner=INNER)
    tr = simulate(PAPER_VEHICLE, GAINS, opts)[0]
    sd = sampled_cascade(cascade, 100.0, variant="held")
    x = np.zeros(len(sd.state_names))
    x[sd.state_names.index("x")], x[sd.state_names.index("y")] = xi0
    iw = [sd.state_names.index(f"w{i}") for i in range(1, 5)]
    x[iw] = 0.0  # deviations from hover
    traj = [x]
    for _ in range(len(tr.t) - 1):
        traj.append(sd.A_d @ traj[-1])
    lin_xy = np.array(traj)[:, [sd.state_names.index("x"), sd.state_names.index("y")]]
    err = np.max(np.abs(lin_xy - tr.xy))
    assert err < 1e-3 * np.max(np.abs(xi0))


def test_lmi_on_a_rotation_is_exact():
    r, th, T = 0.9, 0.3, 0.01
    A = r * np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    res = discrete_lyapunov_decay(A, T)
    assert res.ok and res.spectral_radius == pytest.approx(r, rel=1e-14)
    assert res.rho_numpy <= res.rho and res.decay_rate_1_s == pytest.approx(-math.log(r) / T, rel=2e-3)


@pytest.mark.parametrize("which", ["reduced", "cascade"])
def test_lmi_certifies_the_sampled_loops(which, cascade):
    sd = sampled_reduced_loop(PAPER_VEHICLE, GAINS, 100.0) if which == "reduced" else sampled_cascade(cascade, 100.0)
    res = sd.lyapunov()
    # numpy re-check: P > 0, the contraction of P does not exceed rho, and rho is near the spectral radius
    assert res.ok and np.linalg.eigvalsh(res.P)[0] > 0
    Q = res.rho ** 2 * res.P - sd.A_d.T @ res.P @ sd.A_d
    assert np.linalg.eigvalsh(0.5 * (Q + Q.T))[0] >= -1e-9 * np.linalg.norm(res.P, 2)
    assert sd.spectral_radius * (1 - 1e-12) <= res.rho_numpy <= res.rho < 1
    assert res.decay_rate_1_s == pytest.approx(sd.decay_rate, rel=2e-3)


def test_reduced_sampled_loop_tends_to_the_continuous_loop():
    from nniquad.analysis.reduced_loop import ReducedLoop

    cont = ReducedLoop.from_vehicle(PAPER_VEHICLE, GAINS).poles_and_damping()
    fast = sampled_reduced_loop(PAPER_VEHICLE, GAINS, 1e4)
    assert fast.decay_rate == pytest.approx(-cont.max_real_part, rel=1e-3)


def test_unstable_loop_has_no_certificate():
    with pytest.raises(SolverError, match="unstable"):
        discrete_lyapunov_decay(np.array([[1.01]]), 0.01)


def _counting(answer):
    """A fake LMI: ``answer(target)`` is the contraction the 'solver' achieves (or None); solves are counted."""
    calls = []

    def solve(target):
        calls.append(target)
        got = answer(target)
        return None if got is None else (got, len(calls))

    return solve, calls


def test_best_decay_bisects_to_a_feasibility_edge_known_in_closed_form():
    from nniquad.analysis.sampled import best_decay

    T, rho_spec, rtol = 0.01, 0.99, 1e-3
    lam_spec = -math.log(rho_spec) / T
    edge = math.exp(-0.37 * lam_spec * T)  # the LMI is feasible exactly for targets >= edge (37 % of the bound)
    solve, calls = _counting(lambda target: target if target >= edge else None)
    rho, _ = best_decay(solve, rho_spec, T, rtol=rtol, max_iter=60)
    lam = -math.log(rho) / T
    assert 0.37 * lam_spec * (1 - 2 * rtol) <= lam <= 0.37 * lam_spec * (1 + 1e-12)
    assert len(calls) < 20


def test_best_decay_keeps_an_answer_that_misses_its_target_but_beats_any_later_one():
    """Near the spectral radius the solver stops just short of the target: that answer is a certificate."""
    from nniquad.analysis.sampled import best_decay

    T, rho_spec, rtol = 0.01, 0.99, 0.02
    short = lambda target: min(1.0 - 1e-12, target * (1 + 5e-6))  # noqa: E731  always 5e-6 short
    solve, calls = _counting(short)
    rho, n = best_decay(solve, rho_spec, T, rtol=rtol, max_iter=8)
    first = math.exp(-(1 - rtol) * -math.log(rho_spec))
    assert rho == pytest.approx(first * (1 + 5e-6), rel=1e-15) and n == 1
    assert len(calls) == 1  # the bracket [achieved, first target] is already within rtol: no bisection


def test_best_decay_gives_up_after_two_solves_when_even_the_slowest_decay_fails():
    from nniquad.analysis.sampled import best_decay

    for answer in (lambda target: None, lambda target: 1.0):  # no answer, or an answer that does not contract
        solve, calls = _counting(answer)
        assert best_decay(solve, 0.99, 0.01, rtol=0.02, max_iter=8) is None
        assert len(calls) == 2
