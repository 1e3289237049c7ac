"""The measurement delay line (``SimOptions.delay_samples``, the cascade family's ``delay_samples``).

Independent references: a hand-written numpy loop of the discrete NNI law on the exact ZOH double
integrator, fed the measurement ``N`` samples old (the simulator's ``linear`` model); the closed-form
characteristic polynomial of that loop, ``z^N (z-1)²(z-α) + (T²/2)(z+1)(k_p (z-α) - β/m)``, derived by hand
from ``1 - z^{-N} P(z) C(z) = 0`` (``P = T²(z+1)/(2(z-1)²)``, ``C = -k_p + (β/m)/(z-α)``,
``α = e^{-ΓδT}``, ``β = (1-α)/δ``), against :func:`~nniquad.analysis.cascade.family.with_delay_line`; and
the full nonlinear simulator from a small offset against the linear sampled family propagated by matrix
powers (two constructions of the same delayed loop: sample flags in CasADi, matrices in numpy).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nniquad.analysis.cascade.family import sampled_family, subsystem_of, with_delay_line
from nniquad.analysis.cascade.region import start_vector
from nniquad.config import TILT_LIMIT_DEG
from nniquad.control.inner_gains import DEFAULT_INNER_LOOP_GAINS
from nniquad.errors import SimulationError
from nniquad.laws.nni import Gains
from nniquad.model.vehicle import PAPER_VEHICLE as V
from nniquad.sim import SimOptions, simulate

G = Gains(kp=3.0, Gamma=2.0, delta=1.0)
RATE = 100.0
T = 1.0 / RATE


def _nni_zoh(g: Gains) -> tuple[float, float]:
    alpha = math.exp(-g.Gamma * g.delta * T)
    return alpha, (1.0 - alpha) / g.delta


def _hand_loop(g: Gains, m: float, xi0: float, n_delay: int, steps: int) -> np.ndarray:
    """Positions ``ξ_k`` of the discrete NNI law on ``ξ'' = a`` (exact ZOH) fed ``ξ_{k-N}`` (``ξ_{j<0} = ξ_0``)."""
    alpha, beta = _nni_zoh(g)
    p, v, z = xi0, 0.0, 0.0
    seen = [xi0] * n_delay  # the line: the vehicle sat at xi0 before take-over
    out = [p]
    for _ in range(steps):
        seen.append(p)
        y = seen.pop(0)
        a = -g.kp * y + z / m
        p, v = p + v * T + 0.5 * a * T * T, v + a * T
        z = alpha * z + beta * y
        out.append(p)
    return np.array(out)


@pytest.mark.parametrize("n_delay", [0, 1, 3])
def test_simulated_line_equals_hand_loop(n_delay):
    """The simulator's linear model with the delay line equals the hand loop at every sample (RK4 is exact on a
    double integrator with a held input); a line one sample shorter or longer does not."""
    steps = 300
    o = SimOptions(model="linear", horizon_s=steps * T, output_dt_s=T, controller_sampling="discrete",
                   noise_rate_hz=RATE, delay_samples=n_delay, xi0=(1.0, -0.5))
    tr = simulate(V, G, o)[0]
    for axis, xi0 in ((0, 1.0), (1, -0.5)):
        got = tr.state[:, tr.state_names.index(("x", "y")[axis])]
        np.testing.assert_allclose(got, _hand_loop(G, V.m, xi0, n_delay, steps), atol=1e-10)
        wrong = _hand_loop(G, V.m, xi0, n_delay + 1, steps)
        assert np.max(np.abs(got - wrong)) > 1e-3


def test_delay_needs_a_sampled_run_and_a_whole_number():
    with pytest.raises(SimulationError, match="sampled run"):
        SimOptions(model="linear", delay_samples=1)
    for bad in (-1, 1.5, True):
        with pytest.raises(SimulationError, match="delay_samples"):
            SimOptions(model="linear", controller_sampling="discrete", delay_samples=bad)
    assert "delay_samples" not in SimOptions(controller_sampling="discrete").to_json()  # old records unchanged


def _hand_split(g: Gains, m: float) -> tuple[np.ndarray, ...]:
    """``(A0, B, K, C_p, B_kd, D_k)`` of the two-axis discrete loop without delay, written by hand."""
    alpha, beta = _nni_zoh(g)
    Phi1, Gam1 = np.array([[1.0, T], [0.0, 1.0]]), np.array([[T * T / 2], [T]])
    Phi, Gam = np.kron(np.eye(2), Phi1), np.kron(np.eye(2), Gam1)  # (p_x, v_x, p_y, v_y)
    C_p = np.kron(np.eye(2), np.array([[1.0, 0.0]]))
    B_kd, D_k = beta * np.eye(2), -g.kp * np.eye(2)
    A0 = np.zeros((6, 6))
    A0[:4, :4], A0[4:, :4], A0[4:, 4:] = Phi, B_kd @ C_p, alpha * np.eye(2)
    B = np.zeros((6, 2))
    B[:4] = Gam
    K = np.hstack([D_k @ C_p, np.eye(2) / m])
    return A0[None], B[None], K, C_p, B_kd, D_k


@pytest.mark.parametrize("n_delay", [1, 2])
def test_delay_line_matches_the_closed_form_polynomial(n_delay):
    alpha, beta = _nni_zoh(G)
    A0, B, K, C_p, B_kd, D_k = _hand_split(G, V.m)
    A, Bd, Kd = with_delay_line(A0, B, K, C_p, B_kd, D_k, n_delay)
    A_d = (A + Bd @ Kd)[0]
    assert A_d.shape == (6 + 2 * n_delay,) * 2
    # one axis: z^N (z-1)^2 (z-alpha) + (T^2/2)(z+1)(kp (z-alpha) - beta/m)
    lhs = np.polymul(np.r_[1.0, np.zeros(n_delay)], np.polymul([1.0, -2.0, 1.0], [1.0, -alpha]))
    rhs = (T * T / 2) * np.polymul([1.0, 1.0], np.polyadd(G.kp * np.array([1.0, -alpha]), [-beta / V.m]))
    axis = np.polyadd(lhs, rhs)
    want = np.sort_complex(np.roots(np.polymul(axis, axis)))
    got = np.sort_complex(np.linalg.eigvals(A_d))
    np.testing.assert_allclose(np.poly(got), np.poly(want), atol=1e-9)


def test_spectral_radius_rises_with_the_delay():
    """At the nominal point of a design the horizontal loop's spectral radius rises with every added sample."""
    rho = []
    for n in range(4):
        fam = sampled_family(V, G, DEFAULT_INNER_LOOP_GAINS, np.ones((1, 6)), tilt_limit_deg=TILT_LIMIT_DEG,
                             rate_hz=RATE, delay_samples=n)
        rho.append(float(np.max(np.abs(np.linalg.eigvals(subsystem_of(fam, "x")[0][0])))))
        line = tuple(f"zcd{j}_{a}" for j in range(1, n + 1) for a in "xy")
        assert fam.state_names[len(fam.state_names) - len(line):] == line
    assert all(b > a for a, b in zip(rho, rho[1:])), rho


@pytest.mark.parametrize("n_delay", [0, 2])
def test_full_simulator_follows_the_delayed_family(n_delay):
    """A 0.1 mm start on the full nonlinear model (motor lag, discrete law, delay line) follows ``A_d^k v r``
    of the sampled family with the same delay (its start vector fills the line with the start); the family
    with one sample less is visibly off."""
    r, steps = 1e-4, 150
    o = SimOptions(model="full", horizon_s=steps * T, output_dt_s=T, controller_sampling="discrete",
                   noise_rate_hz=RATE, motor_lag=True, delay_samples=n_delay, xi0=(r, 0.0))
    tr = simulate(V, G, o)[0]
    x_sim = tr.state[:, tr.state_names.index("x")]

    def predicted(n: int) -> np.ndarray:
        fam = sampled_family(V, G, DEFAULT_INNER_LOOP_GAINS, np.ones((1, 6)), tilt_limit_deg=TILT_LIMIT_DEG,
                             rate_hz=RATE, delay_samples=n)
        A = subsystem_of(fam, "x")[0][0]
        s = start_vector(fam, "x") * r
        out = []
        for _ in range(steps + 1):
            out.append(s[0])
            s = A @ s
        return np.array(out)

    scale = np.max(np.abs(x_sim))
    assert np.max(np.abs(x_sim - predicted(n_delay))) <= 1e-4 * scale
    if n_delay:
        assert np.max(np.abs(x_sim - predicted(n_delay - 1))) > 1e-2 * scale


def test_the_robust_default_delays_the_robust_scenarios_only(run_cli):
    """``ROBUST_DELAY_SAMPLES`` is the robust objective's default; the nominal objective has none, and ``tune``
    refuses a delay it would not use."""
    from nniquad.config import ROBUST_DELAY_SAMPLES
    from nniquad.tuning.tune import TuneOptions

    assert TuneOptions(model="full").delay_samples == ROBUST_DELAY_SAMPLES
    assert TuneOptions(model="full", delay_samples=0).delay_samples == 0
    assert TuneOptions(model="reduced").delay_samples == 0
    code, _, err = run_cli("tune", "--model", "reduced", "--delay-samples", "2")
    assert code != 0 and "--delay-samples" in err
