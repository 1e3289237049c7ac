"""Section 'Simulation results': arithmetic, the described response and the full vehicle."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from nniquad.analysis.reduced_loop import ReducedLoop
from nniquad.laws.nni import Gains
from nniquad.sim import metrics as MT
from nniquad.proofs import simulation as SIM
from nniquad.proofs.claims import FAILS, HOLDS, HOLDS_WITH_CORRECTION


def test_delta_min_and_wrong_inputs():
    assert SIM.delta_min().verdict == HOLDS
    assert 1 / (0.64 * 0.25 * 25) == 0.25  # the printed arithmetic, in floats
    assert SIM.delta_min(m="0.468").verdict == FAILS
    assert SIM.delta_min(chosen="0.45").verdict == FAILS


def test_simulation_claim_fails_with_numbers_from_a_second_integrator():
    r = SIM.simulation_claim()
    assert r.verdict == FAILS
    A = ReducedLoop(0.5, Gains(5.0, 160.0, 0.6)).closed_loop_A()
    x0 = np.array([2.0, 0, 0, -1.5, 0, 0])
    t = np.linspace(0, 400, 40001)
    sol = solve_ivp(lambda _t, x: A @ x, (0, 400), x0, t_eval=t, method="DOP853", rtol=1e-10, atol=1e-12)
    xy = sol.y[[0, 3]].T
    ov = MT.overshoot_pct(t, xy)
    shape = r.evidence["response (expm, dt = 0.01 s, 400 s)"]
    assert abs(ov - shape["overshoot_pct (nniquad.sim.metrics)"]) < 0.05  # percent points
    st = MT.settling_time(t, xy)
    assert abs(st - shape["settling_s (nniquad.sim.metrics, 2 % band)"]) < 0.05  # s


def test_simulation_claim_can_hold_from_a_slow_eigenvector():
    # poles -1, -2, -3 (m = 0.5): kp = 11, Gamma = 30, delta = 0.2; start on the eigenvector of -1
    g = Gains(kp=11.0, Gamma=30.0, delta=0.2)
    A3 = ReducedLoop(0.5, g).closed_loop_A_axis()
    lam, V = np.linalg.eig(A3)
    v = np.real(V[:, np.argmin(np.abs(lam + 1))])
    v = v / v[0]
    x0 = np.concatenate([2 * v, -1.5 * v])
    assert SIM.simulation_claim(ReducedLoop(0.5, g), state0=x0, horizon_s=30.0).verdict == HOLDS


def test_full_model_variant_gains_hold():
    r = SIM.full_model_stability(gains=SIM.CORRECTED_FULL_MODEL_GAINS, horizon_s=60.0)
    assert r.verdict == HOLDS


def test_full_model_paper_gains():
    r = SIM.full_model_stability(horizon_s=180.0)
    assert r.verdict == HOLDS_WITH_CORRECTION
    win = r.evidence["full model (nniquad.sim.simulate)"]["max distance per 60 s window [m]"]
    assert win[-1] > win[0] > 2.5  # growing oscillation


def _shape_of(p):
    t = np.linspace(0.0, 10.0, 2001)
    xy = np.outer(p(t), [0.8, -0.6])  # along the start direction of (2, -1.5)
    return SIM._shape(t, xy)


def test_smooth_response_needs_all_three_conditions():
    """The claim's words are 'smooth, no oscillations or overshoot': each condition alone is not enough."""
    smooth = _shape_of(lambda t: np.exp(-t))
    assert SIM.smooth_response(smooth)
    # wiggles without ever passing the origin: no overshoot, no zero crossing, but local extrema
    wiggle = _shape_of(lambda t: np.exp(-t) * (1.0 + 0.5 * np.sin(6.0 * t)))
    assert wiggle["overshoot_pct (nniquad.sim.metrics)"] <= 0.1
    assert wiggle["zero crossings along the initial direction"] == 0
    assert wiggle["local extrema (oscillations)"] > 0
    assert not SIM.smooth_response(wiggle)
    # dips 0.05 % past the origin and comes back: overshoot within 0.1 %, but a zero crossing
    dip = _shape_of(lambda t: np.exp(-t) - 0.0005 * (1 - np.exp(-t)) * np.exp(-(t - 10.0) ** 2 / 20.0))
    assert dip["overshoot_pct (nniquad.sim.metrics)"] <= 0.1
    assert dip["zero crossings along the initial direction"] > 0
    assert not SIM.smooth_response(dip)
