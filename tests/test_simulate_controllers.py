"""The PD comparison controllers of nniquad.sim ("pd_velocity": PDGains, "pd_filtered": PDFilteredGains).

Checked against independent computations: the matrix exponential of the
closed-form linear loops (ξ'' = -kp ξ - kd ξ' with the true velocity; the
three-state loop with the dirty-derivative filter), and the limit τ_f -> 0 in
which the filtered derivative becomes the true one.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from nniquad import sim
from nniquad.config import XI0_M
from nniquad.errors import GainError, SimulationError
from nniquad.laws.nni import PAPER_GAINS, Gains
from nniquad.sim import SimOptions
from nniquad.laws.pd_filtered import PDFilteredGains
from nniquad.laws.pd_velocity import PDGains
from nniquad.model.vehicle import PAPER_VEHICLE

XI0 = np.array(XI0_M)


def _positions_expm(A: np.ndarray, x0_axis: list[np.ndarray], t: np.ndarray) -> np.ndarray:
    """Positions (first state) of two independent axes propagated exactly: shape (N, 2)."""
    out = np.empty((t.size, 2))
    for axis, x0 in enumerate(x0_axis):
        out[:, axis] = [(expm(A * tk) @ x0)[0] for tk in t]
    return out


@pytest.mark.parametrize("true_mass", [None, 0.8])
def test_pd_velocity_linear_matches_matrix_exponential(true_mass):
    kp, kd = 4.0, 3.0
    opts = SimOptions(model="linear", horizon_s=8.0, true_mass_kg=true_mass)
    tr = sim.simulate(PAPER_VEHICLE, PDGains(kp, kd), opts)[0]
    # the plant realises the command with the nominal mass: xi'' = (m_nom/m) a_h
    r = 1.0 if true_mass is None else PAPER_VEHICLE.m / true_mass
    A = np.array([[0.0, 1.0], [-r * kp, -r * kd]])
    ref = _positions_expm(A, [np.array([XI0[0], 0.0]), np.array([XI0[1], 0.0])], tr.t)
    # RK4 at 1 ms on a loop with |λ| ~ 2 1/s: error far below a micrometre
    assert np.max(np.abs(tr.xy - ref)) < 1e-8


def test_pd_filtered_linear_matches_matrix_exponential():
    kp, kd, tau = 4.0, 3.0, 0.05
    opts = SimOptions(model="linear", horizon_s=8.0)
    tr = sim.simulate(PAPER_VEHICLE, PDFilteredGains(kp, kd, tau), opts)[0]
    # per axis [xi, v, d]: v' = -kp xi - kd (xi - d)/tau, d' = (xi - d)/tau, d(0) = xi(0)
    A = np.array([[0.0, 1.0, 0.0],
                  [-kp - kd / tau, 0.0, kd / tau],
                  [1.0 / tau, 0.0, -1.0 / tau]])
    ref = _positions_expm(A, [np.array([XI0[0], 0.0, XI0[0]]), np.array([XI0[1], 0.0, XI0[1]])], tr.t)
    assert np.max(np.abs(tr.xy - ref)) < 1e-8
    # the filter state is stored in the controller-state columns and starts at the initial position
    np.testing.assert_allclose(tr.z_c[0], XI0)


def test_pd_filtered_tends_to_pd_velocity_as_tau_goes_to_zero():
    kp, kd = 6.0, 4.0
    base = SimOptions(model="reduced", horizon_s=6.0)
    ref = sim.simulate(PAPER_VEHICLE, PDGains(kp, kd), base)[0]
    taus = [0.04, 0.01, 0.0025]
    res = sim.simulate(PAPER_VEHICLE, [PDFilteredGains(kp, kd, tau) for tau in taus], base)
    err = np.max(np.abs(res.xy - ref.xy[None]), axis=(1, 2))
    assert np.all(np.diff(err) < 0), err
    # first order in tau: shrinking tau 16-fold shrinks the error at least 8-fold; 1 cm at 2.5 ms
    assert err[-1] < err[0] / 8
    assert err[-1] < 0.01


def test_pd_controllers_on_the_full_vehicle_settle_within_the_tilt_limit():
    opts = SimOptions(model="full", horizon_s=12.0)
    for gains in (PDGains(kp=4.0, kd=4.0), PDFilteredGains(kp=4.0, kd=4.0, tau_f=0.02)):
        controller = gains.controller
        m = sim.simulate(PAPER_VEHICLE, gains, opts)[0].metrics()
        assert m.settling_s is not None and m.settling_s < 10.0, (controller, m)
        assert m.peak_tilt_deg < 31.0
        assert not m.diverged


def test_pd_velocity_ignores_position_noise_only_in_the_derivative():
    """With noise the PD law still sees the noisy position; pd_velocity's derivative term stays clean."""
    opts = SimOptions(model="reduced", horizon_s=10.0, noise_sigma_m=0.01, seed=3)
    clean = sim.simulate(PAPER_VEHICLE, PDGains(kp=4.0, kd=4.0), opts)[0].metrics()
    dirty = sim.simulate(PAPER_VEHICLE, PDFilteredGains(kp=4.0, kd=4.0, tau_f=0.02), opts)[0].metrics()
    assert clean.tilt_jitter_rms_deg is not None and dirty.tilt_jitter_rms_deg is not None
    # differentiating 1 cm noise at 100 Hz through a 20 ms filter: much more tilt jitter
    assert dirty.tilt_jitter_rms_deg > 2 * clean.tilt_jitter_rms_deg


def test_each_law_has_its_own_compiled_functions_and_the_default_is_the_paper_law():
    assert PAPER_GAINS.controller == "nni"
    assert sim.step_function("linear").name() == "step_linear_nni"
    assert sim.models.chunk_function("linear", 10).name() == "nniquad_chunk_linear_nni_10"
    assert sim.models.chunk_function("linear", 10, "pd_filtered").name() == "nniquad_chunk_linear_pd_filtered_10"
    # NNI results do not depend on whether the PD functions were built
    a = sim.simulate(PAPER_VEHICLE, PAPER_GAINS, SimOptions(model="linear", horizon_s=2.0))[0]
    sim.simulate(PAPER_VEHICLE, PDFilteredGains(4.0, 3.0), SimOptions(model="linear", horizon_s=2.0))
    b = sim.simulate(PAPER_VEHICLE, PAPER_GAINS, SimOptions(model="linear", horizon_s=2.0))[0]
    np.testing.assert_array_equal(a.xy, b.xy)


def test_gain_conversion_and_validation():
    assert sim.to_gains((2, 3), "pd_velocity") == PDGains(2.0, 3.0)
    assert sim.to_gains({"kp": 2, "kd": 3, "tau_f": 0.1}, "pd_filtered") == PDFilteredGains(2.0, 3.0, 0.1)
    p = sim.SimParams.from_options(PAPER_VEHICLE, PDFilteredGains(2.0, 3.0, 0.1), SimOptions())
    # the gains sit in their own named entries, not in the NNI slots
    names = [f.name for f in p.layout]
    assert names[:3] == ["gains.kp", "gains.kd", "gains.tau_f"] and "gains.Gamma" not in names
    assert tuple(p.vector()[:3]) == (2.0, 3.0, 0.1)
    assert sim.SimParams.from_vector(p.vector(), "pd_filtered") == p
    with pytest.raises(SimulationError, match="unknown controller"):
        sim.param_layout("pid")
    with pytest.raises(GainError):  # a block of one law where another is needed
        sim.to_gains(PDGains(1.0, 1.0), "nni")
    with pytest.raises(GainError):
        sim.to_gains(PAPER_GAINS, "pd_velocity")
    with pytest.raises(GainError, match="one controller law"):
        sim.simulate(PAPER_VEHICLE, [PDGains(1.0, 1.0), PAPER_GAINS], SimOptions(model="linear", horizon_s=1.0))
    for bad in [(-1.0, 1.0), (1.0, float("nan")), (True, 1.0)]:
        with pytest.raises(GainError):
            PDGains(*bad)
    with pytest.raises(GainError):
        PDFilteredGains(1.0, 1.0, 0.0)
    with pytest.raises(GainError):
        sim.to_gains((1.0,), "pd_velocity")
    # the filter pole must be resolved by the RK4 step
    with pytest.raises(SimulationError, match="tau_f"):
        sim.simulate(PAPER_VEHICLE, PDFilteredGains(1.0, 1.0, 1e-4), SimOptions(model="linear", horizon_s=1.0))


@pytest.mark.parametrize("gains", [Gains(5.0, 160.0, 0.6), PDGains(4.0, 3.0), PDFilteredGains(4.0, 3.0, 0.05)],
                         ids=["nni", "pd_velocity", "pd_filtered"])
def test_time_scaled_gains_run_the_same_loop_faster(gains):
    """``gains.time_scaled(λ)`` on the linear model traces ξ(λ t): compared run against run, sample by sample."""
    from nniquad.sim import SimOptions, simulate

    lam, T = 2.0, 3.0
    slow = simulate(None, gains, SimOptions(model="linear", horizon_s=T, output_dt_s=0.01))[0]
    fast = simulate(None, gains.time_scaled(lam), SimOptions(model="linear", horizon_s=T / lam, output_dt_s=0.005))[0]
    np.testing.assert_allclose(fast.xy, slow.xy, atol=1e-7)
    assert type(gains.time_scaled(lam)) is type(gains)
    if isinstance(gains, Gains):  # m kp delta, hence the sector bound, is invariant
        assert gains.time_scaled(3.0).kp * gains.time_scaled(3.0).delta == pytest.approx(gains.kp * gains.delta)
    with pytest.raises(GainError):
        gains.time_scaled(0.0)
